//! The operator's live-mode messages over the WebSocket (`crate::ws`): Go live and
//! Leave live ([`ClientMessage::Live`]), Record ([`ClientMessage::Record`]) and Stop
//! recording ([`ClientMessage::RecordStop`]), carried out by the playback task
//! ([`crate::playback::Playback::live_mode`]); refusals come back as coded
//! [`ServerMessage::Error`]s.
//!
//! - Go live is refused while `[live]` is off ([`Code::LiveOff`]), while the e-stop
//!   is latched ([`Code::LiveEstopLatched`]: going live never releases it), while a
//!   playlist runs ([`Code::PlayerBusy`]) and on a family without live motion.
//! - Record is refused for a name that is no valid show name, or one the store holds
//!   already ([`Code::RecordNameTaken`]: a recording never replaces a show).
//! - Stop recording stores the show as a native show file, imported and checked
//!   against the installation exactly as an upload is (`PUT /api/shows/{name}`), and
//!   answers [`ServerMessage::Recorded`]; the app then lists it. Should a show of the
//!   same name have been uploaded meanwhile, the recording is stored as `name 2`
//!   (`name 3`…) rather than lost or replacing it (past `name 999`, or
//!   for a name at the length limit, it replaces the show, as an upload would).

use floatball_shared::api::{ClientMessage, ServerMessage};
use floatball_shared::codes::{Code, Coded, Params};
use floatball_shared::params;
use floatball_shared::show::{Show, ShowFormat};
use tokio::sync::mpsc;

use crate::playback::LiveError;
use crate::state::AppState;
use crate::store::ShowName;

/// Carries out a live-mode message away from the session's reader; a refusal or the
/// answer goes to `replies`.
pub fn spawn_request(
    state: &AppState,
    message: ClientMessage,
    replies: mpsc::Sender<ServerMessage>,
) {
    let state = state.clone();
    tokio::spawn(async move {
        if let Some(reply) = carry_out(&state, message).await {
            if let ServerMessage::Error { message, .. } = &reply {
                tracing::warn!("live mode: {message}");
            }
            let _ = replies.send(reply).await;
        }
    });
}

/// The answer to a live-mode message, if it has one.
async fn carry_out(state: &AppState, message: ClientMessage) -> Option<ServerMessage> {
    match message {
        ClientMessage::Live { on: true } if !state.config().live.enabled => {
            Some(ServerMessage::from_template(Code::LiveOff, Params::new()))
        }
        ClientMessage::Live { on } => {
            let result = state.playback().live_mode(on).await;
            if result.is_ok() {
                tracing::info!("live mode {}", if on { "requested" } else { "left" });
            }
            result.err().map(|error| refusal(&error))
        }
        ClientMessage::Record { name } => {
            let name = match ShowName::parse_new(&name) {
                Ok(name) => name,
                Err(reason) => {
                    return Some(ServerMessage::from_template(
                        Code::BadShowName,
                        params! {"reason" => reason},
                    ));
                }
            };
            if state.shows().contains(name.as_str()) {
                return Some(ServerMessage::from_template(
                    Code::RecordNameTaken,
                    params! {"name" => name.as_str()},
                ));
            }
            let result = state.playback().record(name.as_str().to_owned()).await;
            result.err().map(|error| refusal(&error))
        }
        ClientMessage::RecordStop => {
            let Some(show) = state.playback().record_stop().await else {
                return Some(ServerMessage::from_template(
                    Code::RecordNothing,
                    Params::new(),
                ));
            };
            Some(store(state, show).await.unwrap_or_else(|error| error))
        }
        _ => None,
    }
}

/// The refusal of a live-mode request.
fn refusal(error: &LiveError) -> ServerMessage {
    match error {
        LiveError::EstopLatched => {
            ServerMessage::from_template(Code::LiveEstopLatched, Params::new())
        }
        LiveError::Refused(refused) => {
            ServerMessage::error(refused.code(), refused.to_string(), refused.params())
        }
        LiveError::Record(refused) => {
            ServerMessage::error(refused.code(), refused.to_string(), refused.params())
        }
        LiveError::Gone => ServerMessage::from_template(Code::PlayerGone, Params::new()),
    }
}

/// Stores a recorded show as an uploaded one is stored: its native file imported and
/// checked against the installation, then put in the store.
async fn store(state: &AppState, show: Show) -> Result<ServerMessage, ServerMessage> {
    let _catalogue = state.lock_catalogue().await;
    let name = ShowName::parse_new(&show.name).map_err(|reason| {
        ServerMessage::from_template(Code::BadShowName, params! {"reason" => reason})
    })?;
    let name = free_name(state, name);
    let storing = state.clone();
    let stored = tokio::task::spawn_blocking(move || {
        let mut bytes = Vec::new();
        show.write_json(&mut bytes)
            .map_err(|error| internal("the recording could not be written", &error))?;
        let imported =
            crate::http::library::import_upload(&name, &bytes, ShowFormat::Json, &storing.config())
                .map_err(|refused| {
                    let refused: crate::store::Refused = refused.into();
                    ServerMessage::error(refused.code, refused.error, refused.params)
                })?;
        let duration_ms = imported.duration_ms();
        storing
            .shows()
            .put(&name, &imported)
            .map_err(|error| internal("the show store failed", &error))?;
        Ok::<_, ServerMessage>((name, duration_ms))
    })
    .await
    .map_err(|error| internal("a background task failed", &error))??;
    let (name, duration_ms) = stored;
    tracing::info!(
        "stored the recording \"{}\" ({duration_ms} ms)",
        name.as_str()
    );
    Ok(ServerMessage::Recorded {
        name: name.as_str().to_owned(),
        duration_ms,
    })
}

/// `base`, or `base 2`, `base 3`… when the store holds it already.
fn free_name(state: &AppState, base: ShowName) -> ShowName {
    if !state.shows().contains(base.as_str()) {
        return base;
    }
    // Bounded: a name at the length limit has no free variant (it is then replaced,
    // as an upload of that name would).
    (2..1000)
        .find_map(|n| {
            ShowName::parse_new(&format!("{} {n}", base.as_str()))
                .ok()
                .filter(|candidate| !state.shows().contains(candidate.as_str()))
        })
        .unwrap_or(base)
}

/// An internal failure, logged, as a coded error.
fn internal(what: &str, error: &dyn std::fmt::Display) -> ServerMessage {
    tracing::error!("{what}: {error}");
    ServerMessage::from_template(Code::Internal, params! {"what" => what})
}
