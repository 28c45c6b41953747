//! The matrix over HTTP: whether a show can run here, and where the simulated balls
//! really are.
//!
//! - `GET /api/plan/{name}`: 200 the bandwidth / feasibility report
//!   ([`PlanReport`]) of a stored show on this installation; 404.
//! - `GET /api/sim/positions`: 200 every simulated gateway's units with their true
//!   positions ([`SimPositions`]; empty when no gateway is simulated), and those of
//!   the simulated MBOX boxes and MOONS' drives (`port = "sim"`).
//! - `GET /api/mbox/timing`: 200 how the motion frames left for the MBOX boxes
//!   ([`MboxTiming`]: frames sent, late frames, a histogram of how late each left
//!   after its slot); 404 when the installation has no MBOX boxes.
//!
//! All need a [`Session`].

use axum::Json;
use axum::extract::State;
use floatball_shared::api::{PlanReport, SimPositions};
use floatball_shared::plan::PlanOptions;
use floatball_shared::plan::report::report;

use super::library::{NameParam, store_failure};
use super::session::Session;
use super::{Failure, blocking};
use crate::mbox::MboxTiming;
use crate::state::AppState;

/// `GET /api/plan/{name}`.
pub async fn plan(
    State(state): State<AppState>,
    _session: Session,
    NameParam(name): NameParam,
) -> Result<Json<PlanReport>, Failure> {
    let planning = state.clone();
    let result = blocking(move || {
        let show = planning.shows().load(&name).map_err(store_failure)?;
        let installation = &planning.config().installation;
        Ok(report(&show, installation, PlanOptions::default()))
    })
    .await?;
    result.map(Json)
}

/// `GET /api/sim/positions`.
pub async fn sim_positions(State(state): State<AppState>, _session: Session) -> Json<SimPositions> {
    let gateways = state
        .gateways()
        .links()
        .iter()
        .filter_map(|link| link.sim_view().map(|view| view.positions(link.index())))
        .collect();
    let mut boxes = Vec::new();
    for sim in state.mbox_sims() {
        boxes.extend(sim.snapshots().await);
    }
    let drives = state
        .scl_sims()
        .map(crate::simulate::scl::SimDrives::snapshots)
        .unwrap_or_default();
    Json(SimPositions {
        gateways,
        boxes,
        drives,
    })
}

/// `GET /api/mbox/timing`.
pub async fn mbox_timing(
    State(state): State<AppState>,
    _session: Session,
) -> Result<Json<MboxTiming>, Failure> {
    state
        .playback()
        .boxes()
        .map(|boxes| Json(boxes.timing()))
        .ok_or_else(|| {
            Failure::new(
                axum::http::StatusCode::NOT_FOUND,
                "this installation has no MBOX boxes",
            )
        })
}
