//! The matrix over HTTP: what the installation is, whether a show can run here, and
//! where the simulated balls really are.
//!
//! - `GET /api/installation`: 200 the calibration (`counts_per_mm`) and every
//!   gateway's family and stations ([`InstallationInfo`]), so that the app can show
//!   the drives' positions in mm beside their counts.
//! - `GET /api/plan/{name}`: 200 the bandwidth / feasibility report
//!   ([`PlanReport`]) of a stored show on this installation; 404. On MOONS' drives
//!   that Start gives compiled programs (`[scl] programs = "upload"`) every ball's Q
//!   program is compiled too: a show Start would refuse (over `tolerance_mm`, too
//!   fast) is not feasible, with the ball and the figure.
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
use floatball_shared::api::{
    GatewayKind, InstallationGateway, InstallationInfo, PlanReport, SimPositions,
};
use floatball_shared::plan::report::report;
use floatball_shared::plan::verdict::{Fix, Why, refuse};
use floatball_shared::plan::{DriveKind, Installation, PlanOptions};
use floatball_shared::scl::qprogram::QProgramError;
use floatball_shared::show::Show;

use super::library::{NameParam, store_failure};
use super::session::Session;
use super::{Failure, blocking};
use crate::config::{SclConfig, SclPrograms};
use crate::mbox::MboxTiming;
use crate::scl::program::{compile_every_ball, qprogram_config};
use crate::state::AppState;

/// `GET /api/installation`.
pub async fn installation(
    State(state): State<AppState>,
    _session: Session,
) -> Json<InstallationInfo> {
    Json(installation_info(&state.config().installation))
}

/// What `GET /api/installation` says about `installation`.
fn installation_info(installation: &Installation) -> InstallationInfo {
    let gateways = installation
        .gateways
        .iter()
        .enumerate()
        .map(|(index, gateway)| InstallationGateway {
            kind: match gateway.kind {
                DriveKind::Uim2503 => GatewayKind::Uim2503,
                DriveKind::Mbox => GatewayKind::Mbox,
                DriveKind::Scl => GatewayKind::Scl,
            },
            port: gateway.port.clone(),
            baud: (gateway.kind != DriveKind::Mbox).then_some(gateway.baud),
            stations: installation.stations_on(index),
        })
        .collect();
    let limits = &installation.limits;
    InstallationInfo {
        rows: limits.rows,
        cols: limits.cols,
        pitch_mm: installation.pitch_mm,
        travel_mm: limits.travel_mm,
        max_speed_mm_s: limits.max_speed_mm_s,
        max_accel_mm_s2: limits.max_accel_mm_s2,
        home_mm: installation.home_mm,
        approach_speed_mm_s: installation.approach_speed_mm_s,
        counts_per_mm: installation.counts_per_mm,
        gateways,
    }
}

/// `GET /api/plan/{name}`.
pub async fn plan(
    State(state): State<AppState>,
    _session: Session,
    NameParam(name): NameParam,
) -> Result<Json<PlanReport>, Failure> {
    let planning = state.clone();
    let result = blocking(move || {
        let show = planning.shows().load(&name).map_err(store_failure)?;
        let config = planning.config();
        let mut plan = report(&show, &config.installation, PlanOptions::default());
        if let Some(scl) = config
            .scl
            .as_ref()
            .filter(|scl| scl.programs == SclPrograms::Upload)
            && plan.feasible
        {
            refuse_uncompilable(&mut plan, &show, &config.installation, scl);
        }
        Ok(plan)
    })
    .await?;
    result.map(Json)
}

/// Compiles every ball's Q program as Start would; when one cannot be, `plan` is not
/// feasible: the first such ball and why, and — when balls are over the tolerance —
/// the tolerance that would take them all.
fn refuse_uncompilable(
    plan: &mut PlanReport,
    show: &Show,
    installation: &Installation,
    scl: &SclConfig,
) {
    let settings = qprogram_config(installation, scl);
    let mut first = None;
    let mut largest_mm: Option<f64> = None;
    for (ball, program) in compile_every_ball(show, &settings).into_iter().enumerate() {
        if let Err(error) = program {
            if let QProgramError::TooFar { deviation_mm, .. } = error {
                largest_mm = Some(largest_mm.map_or(deviation_mm, |mm| mm.max(deviation_mm)));
            }
            first.get_or_insert(Why::Program { ball, error });
        }
    }
    if let Some(why) = first {
        let fixes: Vec<Fix> = largest_mm
            .map(|mm| Fix::Tolerance {
                tolerance_mm: mm.ceil(),
                deviation_mm: mm,
            })
            .into_iter()
            .collect();
        refuse(plan, &why, &fixes);
    }
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
            Failure::coded(
                axum::http::StatusCode::NOT_FOUND,
                floatball_shared::codes::Code::NoMboxBoxes,
                "this installation has no MBOX boxes",
            )
        })
}
