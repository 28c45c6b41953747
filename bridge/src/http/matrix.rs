//! The matrix over HTTP: what the installation is, whether a show can run here, and
//! where the simulated balls really are.
//!
//! - `GET /api/installation`: 200 the calibration (`counts_per_mm`) and every
//!   gateway's family and stations ([`InstallationInfo`]), so that the app can show
//!   the drives' positions in mm beside their counts.
//! - `PUT /api/installation` (an [`Operator`]): body [`InstallationInfo`], checked,
//!   saved into `floatball.toml` and applied while idle ([`crate::install`]); 200 the
//!   installation now; 422 `installation_invalid` listing every problem; 409
//!   `installation_busy` (not idle, or a Start pending) or `installation_not_live`
//!   (a change to the gateways of MBOX boxes or MOONS' drives); 500
//!   `installation_not_saved`.
//! - `POST /api/gateways/{gateway}/baud` (an [`Operator`]): body [`BaudRequest`]; a
//!   UIM2503 gateway's line to another speed (9600 to 115200) through
//!   [`crate::ports::uim2503::Link::change_baud`], then saved into `floatball.toml` like a
//!   `PUT`; 200 [`BaudChanged`]; 404 `no_such_gateway`; 409 `installation_busy`,
//!   `estop_latched` or `gateway_not_connected`; 422 `baud_not_allowed`; 502
//!   `baud_not_answering` or `baud_port_refused` (the line is back at its old
//!   speed): the link's coded [`BaudError`].
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
//! All need a [`Session`]; `PUT` an [`Operator`].

use axum::Json;
use axum::body::Bytes;
use axum::extract::Path as AxumPath;
use axum::extract::State;
use axum::http::StatusCode;
use floatball_shared::api::{
    BaudChanged, BaudRequest, InstallationInfo, PlanReport, Problem, SimPositions,
};
use floatball_shared::codes::{Code, Params};
use floatball_shared::plan::Installation;
use floatball_shared::plan::report::{report, report_of};
use floatball_shared::plan::verdict::refuse;
use floatball_shared::show::Show;
use floatball_shared::uim2503::plan::PlanOptions;

use super::library::{NameParam, store_failure};
use super::session::{Operator, Session};
use super::{Failure, blocking, json_body};
use crate::config::{ConfigError, SclConfig};
use crate::install::{self, InstallError};
use crate::ports::mbox::MboxTiming;
use crate::ports::scl::program::{compile_show, qprogram_config};
use crate::ports::uim2503::BaudError;
use crate::state::AppState;

/// `GET /api/installation`.
pub async fn installation(
    State(state): State<AppState>,
    _session: Session,
) -> Json<InstallationInfo> {
    Json(install::info(&state.config().installation))
}

/// `PUT /api/installation`.
pub async fn put_installation(
    State(state): State<AppState>,
    Operator(_session): Operator,
    body: Bytes,
) -> Result<Json<InstallationInfo>, Failure> {
    let new: InstallationInfo = json_body(&body, "installation")?;
    install::put(&state, new)
        .await
        .map(Json)
        .map_err(|error| install_failure(&error))
}

/// The answer to a refused installation or line speed: the error's code, parameters
/// and words (its code's template, see [`InstallError`]), with each problem of an
/// invalid installation.
pub fn install_failure(error: &InstallError) -> Failure {
    let status = match error {
        InstallError::Invalid(_) | InstallError::BaudNotAllowed { .. } => {
            StatusCode::UNPROCESSABLE_ENTITY
        }
        InstallError::Busy { .. } | InstallError::NotLive => StatusCode::CONFLICT,
        InstallError::NotSaved(_) => StatusCode::INTERNAL_SERVER_ERROR,
        InstallError::NoSuchGateway { .. } => StatusCode::NOT_FOUND,
        InstallError::Baud { error, .. } => match error {
            BaudError::OutOfRange { .. } => StatusCode::UNPROCESSABLE_ENTITY,
            BaudError::EstopLatched | BaudError::Link(_) => StatusCode::CONFLICT,
            BaudError::Port { .. } | BaudError::NotAnswering { .. } => StatusCode::BAD_GATEWAY,
        },
    };
    let mut failure = Failure::of(status, error);
    if let InstallError::Invalid(problems) = error {
        for problem in problems.iter().flat_map(ConfigError::problems) {
            let reason = problem.reason();
            failure.body.problems.push(Problem {
                code: Code::InstallationProblem.as_str().to_owned(),
                params: floatball_shared::params!("reason" => reason),
            });
            failure.body.details.push(reason);
        }
    }
    failure
}

/// `POST /api/gateways/{gateway}/baud`.
pub async fn change_baud(
    State(state): State<AppState>,
    Operator(_session): Operator,
    AxumPath(gateway): AxumPath<usize>,
    body: Bytes,
) -> Result<Json<BaudChanged>, Failure> {
    let request: BaudRequest = json_body(&body, "line speed")?;
    install::change_baud(&state, gateway, request.baud)
        .await
        .map(Json)
        .map_err(|error| install_failure(&error))
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
        let Some(scl) = config.scl().filter(|scl| scl.programs.compiled()) else {
            // The show is planned as it is freed: never whole beside its plan.
            return Ok(report_of(
                show,
                &config.installation,
                PlanOptions::default(),
            ));
        };
        let mut plan = report(&show, &config.installation, PlanOptions::default());
        if plan.feasible {
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
    if let Err(uncompilable) = compile_show(
        show,
        &qprogram_config(installation, scl),
        scl.programs.streaming(),
    ) {
        refuse(plan, &uncompilable.why, &uncompilable.fixes);
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
            Failure::from_template(StatusCode::NOT_FOUND, Code::NoMboxBoxes, Params::new())
        })
}
