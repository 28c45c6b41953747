//! The armer: while the matrix is idle and a playlist exists, it has the player load
//! the first entry's tables ahead of Start ([`crate::playback::Playback::arm`]), so
//! that Start needs only the approach. The status says so (`armed`).
//!
//! It arms once per disarm ([`Playback::disarms`](crate::playback::Playback::disarms)
//! counts every disarm, run and stop of the player): when the status is `idle`,
//! nothing is armed, no Start or Reset is being prepared
//! ([`AppState::starts_pending`]), the e-stop is not latched, every gateway is up, and
//! the quiet time after the last [`disarm`] is over. A playlist that Start would refuse
//! is not armed (and not tried again until something changes).
//!
//! [`disarm`] is the one entry point for whatever may change what the units hold or
//! what plays first: console lines, a new playlist, a changed show of the playlist, a
//! new installation, commissioning commands.

use std::time::Duration;

use floatball_shared::api::PlayerState;

use crate::state::AppState;

/// How often the armer looks when the status does not change.
const LOOK_EVERY: Duration = Duration::from_millis(250);

/// Drops what is armed and keeps arming away for
/// [`ARM_QUIET`](crate::playback::ARM_QUIET): call it before anything that could change
/// what the units hold (a console line or commissioning command to a gateway, a new
/// installation) or what plays first (a new playlist, a changed show of it).
pub fn disarm(state: &AppState) {
    state.playback().disarm();
}

/// Starts the armer for `state` (nothing to do for MBOX boxes and MOONS' drives); it
/// ends when the bridge stops. Must run inside the async runtime.
pub fn spawn(state: AppState) {
    if !state.playback().arms() {
        return;
    }
    tokio::spawn(run(state));
}

/// Whether the matrix may be armed now, as far as `state` shows.
fn may_arm(state: &AppState) -> bool {
    let playback = state.playback();
    // Copied out: no guard held while the other checks take their locks.
    let (player_state, armed) = {
        let status = state.subscribe_status();
        let status = status.borrow();
        (status.state, status.armed.is_some())
    };
    player_state == PlayerState::Idle
        && !armed
        && !state.starts_pending()
        && !state.commission().busy()
        && !playback.latch().is_latched()
        && playback
            .links()
            .iter()
            .all(crate::ports::uim2503::Link::is_up)
        && playback.arming_allowed()
}

async fn run(state: AppState) {
    let mut status = state.subscribe_status();
    let mut stopping = state.stopping();
    let mut tried: Option<u64> = None;
    loop {
        tokio::select! {
            changed = status.changed() => {
                if changed.is_err() {
                    return;
                }
            }
            _ = stopping.changed() => return,
            () = tokio::time::sleep(LOOK_EVERY) => {}
        }
        if *stopping.borrow() {
            return;
        }
        let disarms = state.playback().disarms();
        if tried == Some(disarms) || !may_arm(&state) {
            continue;
        }
        if state.playlist().get().entries.is_empty() {
            continue;
        }
        tried = Some(disarms);
        // The playlist prepared last (by an arming or a Start) is armed as it is: a
        // show that ended is armed again without reading or planning it again.
        let Ok(playlist) = crate::control::playlist(&state).await else {
            continue;
        };
        if state.playback().arm(playlist, disarms).await {
            tracing::debug!("arming the playlist's first entry while the matrix is idle");
        }
    }
}
