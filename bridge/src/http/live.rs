//! `GET` / `PUT /api/live/patch`: the patch of live input (`[live]` in
//! `floatball.toml`, `crate::config::live`) as the app's Patch page shows and edits
//! it.
//!
//! `PUT` takes a whole [`Patch`] and, under the catalogue lock (the one lock every
//! change to `floatball.toml` takes, so it never races `PUT /api/installation`):
//! 1. refused while the player is not idle or a Start is pending (409 `patch_busy`,
//!    as the installation is);
//! 2. checked against the installation (422 `patch_invalid`, every problem of
//!    [`Patch::problems`] coded in `problems[]`);
//! 3. written into `[live]` ([`crate::config::live::edit_patch`]: comments and other
//!    keys kept), the whole file checked as `floatball check` checks it (422
//!    `installation_invalid` should anything else in it be wrong), saved atomically
//!    ([`crate::durable::write_atomic`]) and made the configuration every reader gets.
//!
//! The live input's receivers ([`crate::live`]) take the new patch from the
//! configuration at once (new universes merged, their multicast groups joined).
//!
//! `GET /api/live/status`: what the receivers see ([`crate::live::LiveStatus`]):
//! counters, sources, universes, whether input is lost, and the targets of the balls
//! `from`… (`count`, 100 unless given, at most [`crate::live::MAX_STATUS_TARGETS`]).

use axum::Json;
use axum::body::Bytes;
use axum::extract::{Query, State};
use axum::http::StatusCode;
use floatball_shared::api::{LivePatch, Problem};
use floatball_shared::codes::{Code, Coded};
use floatball_shared::live::patch::Patch;
use floatball_shared::params;

use super::session::{Operator, Session};
use super::{Failure, json_body};
use crate::config::{self, Config, Overrides};
use crate::install::{self, InstallError};
use crate::state::AppState;

/// Largest `PUT /api/live/patch` body, bytes: 10,000 balls each with its own
/// profile fit.
pub const MAX_PATCH_BYTES: usize = 4 * 1024 * 1024;

/// The patch of `config` as the app needs it.
pub fn live_patch(config: &Config) -> LivePatch {
    let live = &config.live;
    LivePatch {
        rows: config.installation.limits.rows,
        cols: config.installation.limits.cols,
        enabled: live.enabled,
        hold_after_ms: live.hold_after_ms,
        artnet: live.artnet,
        sacn: live.sacn,
        universes: live.patch.universes(),
        patch: live.patch.clone(),
    }
}

/// `GET /api/live/status`'s query: `?from=0&count=100`.
#[derive(Debug, Clone, Copy, Default, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StatusQuery {
    /// The first ball whose target is given.
    #[serde(default)]
    pub from: usize,
    /// How many balls' targets (100 unless given).
    pub count: Option<usize>,
}

/// `GET /api/live/status` (see the module).
pub async fn get_status(
    State(state): State<AppState>,
    _session: Session,
    Query(query): Query<StatusQuery>,
) -> Json<crate::live::LiveStatus> {
    let input = state.live_input();
    Json(crate::live::status(
        &input,
        tokio::time::Instant::now(),
        query.from,
        query.count.unwrap_or(100),
    ))
}

/// `GET /api/live/patch`.
pub async fn get_patch(State(state): State<AppState>, _session: Session) -> Json<LivePatch> {
    Json(live_patch(&state.config()))
}

/// `PUT /api/live/patch` (see the module).
pub async fn put_patch(
    State(state): State<AppState>,
    Operator(_session): Operator,
    body: Bytes,
) -> Result<Json<LivePatch>, Failure> {
    let patch: Patch = json_body(&body, "patch")?;
    let _catalogue = state.lock_catalogue().await;
    if let Err(InstallError::Busy { state: busy }) = install::idle(&state) {
        return Err(Failure::from_template(
            StatusCode::CONFLICT,
            Code::PatchBusy,
            params! {"state" => busy},
        ));
    }
    let current = state.config();
    let balls =
        current.installation.limits.rows as usize * current.installation.limits.cols as usize;
    let problems = patch.problems(balls);
    if !problems.is_empty() {
        let mut failure = Failure::from_template(
            StatusCode::UNPROCESSABLE_ENTITY,
            Code::PatchInvalid,
            params! {"problems" => problems.len()},
        );
        for problem in &problems {
            failure.body.problems.push(Problem {
                code: problem.code().as_str().to_owned(),
                params: problem.params(),
            });
            failure.body.details.push(problem.to_string());
        }
        return Err(failure);
    }
    let dir = state.data_dir().to_owned();
    let start = current.live.matrix_start;
    let listen = current.listen;
    let saved = super::blocking(move || save(&dir, &patch, start, listen)).await?;
    let checked = saved.map_err(|error| super::matrix::install_failure(&error))?;
    // Only `[live]` changed: the rest stays as the bridge runs it (command-line
    // overrides and all).
    let mut config = (*current).clone();
    config.live = checked.live;
    let answer = live_patch(&config);
    tracing::info!(
        "saved a new patch: {} balls on {} universe(s)",
        answer.patch.balls.len(),
        answer.universes.len()
    );
    state.replace_config(config);
    Ok(Json(answer))
}

/// Writes `patch` into `floatball.toml` in `dir` and checks the whole file; the
/// configuration it now says.
fn save(
    dir: &std::path::Path,
    patch: &Patch,
    start: (u16, u16),
    listen: std::net::SocketAddr,
) -> Result<Config, InstallError> {
    let path = dir.join(config::FILE_NAME);
    let old = std::fs::read_to_string(&path)
        .map_err(|error| InstallError::NotSaved(format!("{}: {error}", path.display())))?;
    let text = config::live::edit_patch(&old, patch, start)
        .map_err(|error| InstallError::NotSaved(error.to_string()))?;
    let overrides = Overrides {
        listen: Some(listen),
        gateway_ports: Vec::new(),
    };
    let config = Config::parse_all(&path, &text, &overrides).map_err(InstallError::Invalid)?;
    if config.live.patch != *patch {
        return Err(InstallError::NotSaved(
            "the edited file does not say what was asked; edit floatball.toml by hand".to_owned(),
        ));
    }
    crate::durable::write_atomic(dir, config::FILE_NAME, text.as_bytes())
        .map_err(|error| InstallError::NotSaved(error.to_string()))?;
    Ok(config)
}
