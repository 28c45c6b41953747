//! The HTTP API under `/api` (`docs/architecture.md` §4; `docs/api.md`).
//!
//! - [`session`]: login, logout, password change, and the extractors that let a
//!   handler run only for a logged-in client ([`session::Session`]) or only once the
//!   initial password is changed ([`session::Operator`]);
//! - [`library`]: the show files and the playlist;
//! - [`matrix`]: the installation's calibration and stations, the feasibility report
//!   of a show, and the simulated balls' positions;
//! - [`qprogram`]: one ball's Q program for MOONS' drives, compiled from a show;
//! - [`commission`]: a UIM2503 gateway's roll call, station assignment and identify
//!   moves;
//! - [`status`]: every gateway's status in full (the live status summarises many);
//! - [`schedule`]: the weekly schedule, the scheduler's state, and the test clock;
//! - [`live`]: the patch of live input (`[live]` in `floatball.toml`);
//!
//! Every error answer is an [`ApiError`] JSON body with the right status code
//! ([`Failure`]); so are unknown `/api` paths (404) and methods (405), and the
//! framework's own refusals (a body over the limit, a malformed request…), which
//! [`json_errors`] rewrites.

pub mod commission;
pub mod library;
pub mod live;
pub mod matrix;
pub mod qprogram;
pub mod schedule;
pub mod session;
pub mod status;

use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::http::{HeaderValue, StatusCode, header};
use axum::middleware::map_response;
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use floatball_shared::api::{ApiError, Problem};
use floatball_shared::codes::{Code, Coded, Params};
use floatball_shared::params;
use serde::de::DeserializeOwned;

use crate::state::AppState;

/// Largest JSON body accepted by the calls other than uploads, bytes.
pub const MAX_JSON_BYTES: usize = 1024 * 1024;

/// Most bytes of a framework refusal's text kept in the JSON answer that replaces it.
const MAX_REFUSAL_TEXT: usize = 4096;

/// The `/api` routes, to be nested under `/api`.
pub fn router(state: &AppState) -> Router<AppState> {
    let upload_limit = DefaultBodyLimit::max(state.config().uploads.max_bytes);
    Router::new()
        .route("/login", post(session::login))
        .route("/logout", post(session::logout))
        .route("/password", post(session::change_password))
        .route("/shows", get(library::list_shows))
        .route(
            "/shows/{name}",
            get(library::get_show)
                .put(library::put_show)
                .delete(library::delete_show)
                .layer(upload_limit),
        )
        .route(
            "/playlist",
            get(library::get_playlist).put(library::put_playlist),
        )
        .route(
            "/installation",
            get(matrix::installation).put(matrix::put_installation),
        )
        .route("/gateways/{gateway}/baud", post(matrix::change_baud))
        .route("/plan/{name}", get(matrix::plan))
        .route("/sim/positions", get(matrix::sim_positions))
        .route("/mbox/timing", get(matrix::mbox_timing))
        .route("/qprogram/{name}", get(qprogram::qprogram))
        .route("/gateways/{gateway}/rollcall", post(commission::rollcall))
        .route("/gateways/{gateway}/assign", post(commission::assign))
        .route("/gateways/{gateway}/identify", post(commission::identify))
        .route("/status/gateways", get(status::gateways))
        .route(
            "/schedule",
            get(schedule::get_schedule).put(schedule::put_schedule),
        )
        .route("/schedule/status", get(schedule::get_status))
        .route("/test/clock", post(schedule::set_test_clock))
        .route(
            "/live/patch",
            get(live::get_patch)
                .put(live::put_patch)
                .layer(DefaultBodyLimit::max(live::MAX_PATCH_BYTES)),
        )
        .route("/live/status", get(live::get_status))
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(map_response(json_errors))
        .layer(DefaultBodyLimit::max(MAX_JSON_BYTES))
        .layer(crate::origin::cors(&state.config().allowed_origins))
}

/// Makes every error answer an [`ApiError`] JSON body: an answer of 400 or above that
/// is not JSON (the framework's refusals are plain text, e.g. "Failed to buffer the
/// request body") becomes one with the same status and headers, a sentence saying
/// what was refused, and the original text in `details`.
pub async fn json_errors(response: Response) -> Response {
    let status = response.status();
    let is_json = response
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|value| value.to_str().ok())
        .is_some_and(|value| value.starts_with("application/json"));
    if is_json || !(status.is_client_error() || status.is_server_error()) {
        return response;
    }
    let (parts, body) = response.into_parts();
    let text = axum::body::to_bytes(body, MAX_REFUSAL_TEXT)
        .await
        .map(|bytes| String::from_utf8_lossy(&bytes).trim().to_owned())
        .unwrap_or_default();
    let failure = match status {
        StatusCode::PAYLOAD_TOO_LARGE => Failure::from_template(
            status,
            Code::BodyTooLarge,
            params! {"limit_bytes" => MAX_JSON_BYTES},
        ),
        StatusCode::UNSUPPORTED_MEDIA_TYPE => {
            Failure::from_template(status, Code::UnsupportedMediaType, Params::new())
        }
        _ if !text.is_empty() => Failure::refused(status, text.clone()),
        _ => Failure::from_template(
            status,
            Code::RequestRefused,
            params! {"status" => status.as_u16()},
        ),
    };
    let details = if text.is_empty() || text == failure.body.error {
        Vec::new()
    } else {
        vec![text]
    };
    let mut rewritten = failure.with_details(details).into_response();
    let own = rewritten.headers().clone();
    for (name, value) in &parts.headers {
        if name != header::CONTENT_TYPE && name != header::CONTENT_LENGTH && !own.contains_key(name)
        {
            rewritten.headers_mut().append(name, value.clone());
        }
    }
    rewritten
}

async fn not_found() -> Failure {
    Failure::from_template(StatusCode::NOT_FOUND, Code::NotFound, Params::new())
}

async fn method_not_allowed() -> Failure {
    Failure::from_template(
        StatusCode::METHOD_NOT_ALLOWED,
        Code::MethodNotAllowed,
        Params::new(),
    )
}

/// An error answer: a status code, an [`ApiError`] body and, for 429, how many seconds
/// to wait.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Failure {
    /// The status code.
    pub status: StatusCode,
    /// The body (boxed: it is large, and every handler returns `Result<_, Failure>`).
    pub body: Box<ApiError>,
    /// `Retry-After`, seconds.
    pub retry_after_s: Option<u64>,
}

impl Failure {
    /// An answer with `status`, a stable `code` and its English sentence; add the
    /// code's parameters with [`Failure::param`].
    pub fn coded(status: StatusCode, code: Code, error: impl Into<String>) -> Self {
        Self {
            status,
            body: Box::new(ApiError::coded(code, error)),
            retry_after_s: None,
        }
    }

    /// An answer with `status`, a stable `code` and its `params`, worded by the code's
    /// English template ([`floatball_shared::codes::english_text`]), the sentence the
    /// app shows in English.
    pub fn from_template(status: StatusCode, code: Code, params: Params) -> Self {
        Self {
            status,
            body: Box::new(ApiError::from_template(code, params)),
            retry_after_s: None,
        }
    }

    /// An answer for a typed error: its code, parameters and English text.
    pub fn of(status: StatusCode, error: &(impl Coded + std::fmt::Display)) -> Self {
        let mut failure = Self::coded(status, error.code(), error.to_string());
        failure.body.params = error.params();
        failure
    }

    /// A refusal of the framework's without a code of its own: code
    /// `request_refused`, parameter `status`.
    fn refused(status: StatusCode, error: impl Into<String>) -> Self {
        Self::coded(status, Code::RequestRefused, error).param("status", status.as_u16())
    }

    /// The same answer with the parameter `name` = `value`.
    #[must_use]
    pub fn param(mut self, name: &str, value: impl std::fmt::Display) -> Self {
        self.body.params.insert(name.to_owned(), value.to_string());
        self
    }

    /// The same answer listing `details` (English).
    #[must_use]
    pub fn with_details(mut self, details: Vec<String>) -> Self {
        self.body.details = details;
        self
    }

    /// The same answer listing every problem of `problems`: their English texts in
    /// `details`, their codes and parameters in `problems`.
    #[must_use]
    pub fn with_problems<'a, E: Coded + std::fmt::Display + 'a>(
        mut self,
        problems: impl IntoIterator<Item = &'a E>,
    ) -> Self {
        for problem in problems {
            self.body.details.push(problem.to_string());
            self.body.problems.push(Problem::of(problem));
        }
        self
    }

    /// A 500 for something that should not fail: logged here, reported in general
    /// words (code `internal`, parameter `what`).
    pub fn internal(what: &str, error: &dyn std::fmt::Display) -> Self {
        tracing::error!("{what}: {error}");
        Self::coded(
            StatusCode::INTERNAL_SERVER_ERROR,
            Code::Internal,
            format!("{what}: {error}"),
        )
        .param("what", what)
    }
}

impl IntoResponse for Failure {
    fn into_response(self) -> Response {
        let mut response = (self.status, axum::Json(*self.body)).into_response();
        if let Some(seconds) = self.retry_after_s {
            response
                .headers_mut()
                .insert(header::RETRY_AFTER, HeaderValue::from(seconds));
        }
        if self.status == StatusCode::UNAUTHORIZED {
            response
                .headers_mut()
                .insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
        }
        response
    }
}

/// Reads a JSON request body; a body that is not the expected JSON is a 400 that says
/// what serde found.
fn json_body<T: DeserializeOwned>(body: &[u8], what: &str) -> Result<T, Failure> {
    serde_json::from_slice(body).map_err(|error| {
        Failure::from_template(
            StatusCode::BAD_REQUEST,
            Code::BadJson,
            params! {"what" => what, "reason" => error},
        )
    })
}

/// Runs slow or blocking work (password hashing, file I/O) off the async threads.
async fn blocking<T: Send + 'static>(
    work: impl FnOnce() -> T + Send + 'static,
) -> Result<T, Failure> {
    tokio::task::spawn_blocking(work)
        .await
        .map_err(|error| Failure::internal("a background task failed", &error))
}
