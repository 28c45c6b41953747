//! PVT (position–velocity–time) motion as the UFQ750 runs it (`docs/uim2503.md` §3, manual §7).
//!
//! - a row is evaluated as a cubic Hermite segment ([`crate::motion::Segment`]), the
//!   evaluation shared by the simulator, the planner, show validation and the preview;
//! - [`rounding`]: a motion in whole counts as rows the unit accepts (inside the
//!   travel along every cubic, within the limits);
//! - [`table`]: a unit's 256-row table with its `MP` parameters and the FIFO,
//!   single-sequence and loop runs, as a state machine advanced by time.

pub mod rounding;
pub mod table;

pub use table::{
    EndReason, Events, Mode, PvtError, PvtTable, ROW_MAX_MS, ROW_MIN_MS, Row, RowStart, RunEnd,
    Stopped, TABLE_ROWS, Watermark,
};
