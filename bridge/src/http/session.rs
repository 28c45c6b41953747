//! Logging in and out, changing the password, and who may call what.
//!
//! - `POST /api/login`: 200 with a token; 401 for a wrong password; 429 with
//!   `Retry-After` after [`MAX_FAILURES`](crate::auth::MAX_FAILURES) wrong passwords
//!   from one address within a minute; 503 with `Retry-After` when every password
//!   check ([`CHECK_PERMITS`](crate::auth::CHECK_PERMITS)) stayed taken for
//!   [`CHECK_QUEUE_WAIT`](crate::auth::CHECK_QUEUE_WAIT) (checks are granted in the
//!   order asked).
//! - `POST /api/logout`: 204; the token is no longer accepted.
//! - `POST /api/password`: 204; 403 for a wrong current password (which counts as a
//!   failed login), 400 for an unacceptable new one, 503 as for a login. Every other
//!   token is ended.
//!
//! A handler that takes a [`Session`] runs only with a valid bearer token (else 401);
//! one that takes an [`Operator`] also only once the initial password is changed
//! (else 403).

use std::net::SocketAddr;

use axum::body::Bytes;
use axum::extract::{ConnectInfo, FromRequestParts, State};
use axum::http::request::Parts;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use floatball_shared::api::{LoginRequest, LoginResponse, PasswordChange};
use floatball_shared::codes::{Code, Params};
use floatball_shared::params;

use super::{Failure, blocking, json_body};
use crate::auth::{Busy, CHECK_QUEUE_WAIT, PasswordError};
use crate::state::AppState;

/// A request with a valid bearer token.
#[derive(Debug, Clone)]
pub struct Session {
    /// The token.
    pub token: String,
}

impl FromRequestParts<AppState> for Session {
    type Rejection = Failure;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, Failure> {
        let token = parts
            .headers
            .get(header::AUTHORIZATION)
            .and_then(|value| value.to_str().ok())
            .and_then(|value| value.strip_prefix("Bearer "))
            .map(str::trim)
            .ok_or_else(|| {
                Failure::coded(
                    StatusCode::UNAUTHORIZED,
                    Code::LoginRequired,
                    "log in first: this call needs an `Authorization: Bearer <token>` header",
                )
            })?;
        if state.tokens().touch(token, state.clock().now()) {
            Ok(Self {
                token: token.to_owned(),
            })
        } else {
            Err(Failure::from_template(
                StatusCode::UNAUTHORIZED,
                Code::SessionExpired,
                Params::new(),
            ))
        }
    }
}

/// A logged-in request allowed to change things: the initial password is changed.
#[derive(Debug, Clone)]
pub struct Operator(pub Session);

impl FromRequestParts<AppState> for Operator {
    type Rejection = Failure;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, Failure> {
        let session = Session::from_request_parts(parts, state).await?;
        if state.password().is_default() {
            return Err(must_change_password());
        }
        Ok(Self(session))
    }
}

/// The 403 for a call refused while the password is the initial one.
pub fn must_change_password() -> Failure {
    Failure::coded(
        StatusCode::FORBIDDEN,
        Code::MustChangePassword,
        "change the initial password (1234) first: POST /api/password",
    )
}

/// The 429 for an address that guessed too often.
fn too_many(wait: std::time::Duration) -> Failure {
    let seconds = (wait.as_secs() + u64::from(wait.subsec_nanos() > 0)).max(1);
    Failure {
        retry_after_s: Some(seconds),
        ..Failure::from_template(
            StatusCode::TOO_MANY_REQUESTS,
            Code::TooManyAttempts,
            params! {"retry_after_s" => seconds},
        )
    }
}

/// Seconds a client is told to wait after a 503 for a busy password check.
const BUSY_RETRY_AFTER_S: u64 = 5;

/// The 503 for a password check that found every permit taken for too long.
fn busy(_: Busy) -> Failure {
    Failure {
        retry_after_s: Some(BUSY_RETRY_AFTER_S),
        ..Failure::from_template(
            StatusCode::SERVICE_UNAVAILABLE,
            Code::LoginBusy,
            params! {"retry_after_s" => BUSY_RETRY_AFTER_S},
        )
    }
}

/// `POST /api/login`.
pub async fn login(
    State(state): State<AppState>,
    ConnectInfo(client): ConnectInfo<SocketAddr>,
    body: Bytes,
) -> Result<axum::Json<LoginResponse>, Failure> {
    let request: LoginRequest = json_body(&body, "login request ({\"password\": \"…\"})")?;
    let started = state.clock().now();
    state
        .login_limiter()
        .attempt(client.ip(), started)
        .map_err(too_many)?;
    let mut permit = match state.password().admit(CHECK_QUEUE_WAIT).await {
        Ok(permit) => permit,
        Err(refused) => {
            // Not a guess: nothing was checked.
            state.login_limiter().forgive(client.ip(), started);
            return Err(busy(refused));
        }
    };
    let checking = state.clone();
    let right =
        blocking(move || checking.password().verify(&mut permit, &request.password)).await?;
    if !right {
        tracing::warn!("wrong password from {}", client.ip());
        return Err(Failure::from_template(
            StatusCode::UNAUTHORIZED,
            Code::WrongPassword,
            Params::new(),
        ));
    }
    state.login_limiter().forgive(client.ip(), started);
    let token = state
        .tokens()
        .issue(state.clock().now())
        .map_err(|error| Failure::internal("cannot make a token", &error))?;
    Ok(axum::Json(LoginResponse {
        token,
        must_change_password: state.password().is_default(),
    }))
}

/// `POST /api/logout`.
pub async fn logout(State(state): State<AppState>, session: Session) -> StatusCode {
    state.tokens().revoke(&session.token);
    StatusCode::NO_CONTENT
}

/// `POST /api/password`.
pub async fn change_password(
    State(state): State<AppState>,
    ConnectInfo(client): ConnectInfo<SocketAddr>,
    session: Session,
    body: Bytes,
) -> Result<Response, Failure> {
    let request: PasswordChange =
        json_body(&body, "password change ({\"old\": \"…\", \"new\": \"…\"})")?;
    let started = state.clock().now();
    state
        .login_limiter()
        .attempt(client.ip(), started)
        .map_err(too_many)?;
    let mut permit = match state.password().admit(CHECK_QUEUE_WAIT).await {
        Ok(permit) => permit,
        Err(refused) => {
            state.login_limiter().forgive(client.ip(), started);
            return Err(busy(refused));
        }
    };
    let changing = state.clone();
    let result = blocking(move || {
        changing
            .password()
            .change(&mut permit, &request.old, &request.new)
    })
    .await?;
    match result {
        Ok(()) => {
            state.login_limiter().forgive(client.ip(), started);
            state.tokens().revoke_others(&session.token);
            tracing::info!("the operator password was changed from {}", client.ip());
            Ok(StatusCode::NO_CONTENT.into_response())
        }
        Err(PasswordError::WrongPassword) => Err(Failure::from_template(
            StatusCode::FORBIDDEN,
            Code::WrongCurrentPassword,
            Params::new(),
        )),
        Err(PasswordError::Unacceptable(rule)) => {
            state.login_limiter().forgive(client.ip(), started);
            Err(Failure::of(StatusCode::BAD_REQUEST, &rule))
        }
        Err(error) => {
            state.login_limiter().forgive(client.ip(), started);
            Err(Failure::internal("cannot change the password", &error))
        }
    }
}
