//! The installation and what every family's plan is judged by (`docs/architecture.md` §4–5):
//!
//! - [`installation`]: the [`Installation`] (which unit hangs where, calibration, lines,
//!   kinds of drive) and the one rule that gives every unit its gateway and station;
//! - [`port`]: a gateway's `port` setting parsed: the simulator, a serial device, or a
//!   serial device server on the network (`tcp://`, `rfc2217://`);
//! - [`report`]: the bandwidth / feasibility report served at `GET /api/plan/{name}`
//!   (UIM2503 lines in figures; every family's verdict);
//! - [`verdict`]: the report's verdict as typed values — why a show cannot run and what
//!   would make it run — each giving its English sentence and its code.
//!
//! What each family plays from is the family's own: UIM2503 rows and streams in
//! [`crate::uim2503`], MBOX frames in [`crate::mbox`], MOONS' Q programs in
//! [`crate::scl`].

pub mod installation;
pub mod port;
pub mod report;
pub mod verdict;

pub use installation::{
    AllocationError, DriveKind, GatewaySpec, Installation, MAX_MBOX_AXES, MAX_UNITS_PER_GATEWAY,
    UnitAddress,
};
