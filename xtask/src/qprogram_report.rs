//! `cargo xtask qprogram-report [options]`: the Q program compiler on a 10-minute demo
//! show, every ball of a 10 × 10 matrix, with figures.
//!
//! Runs the example `shared/examples/qprogram_report.rs` in a release build: the demo
//! wave (`show::demo`) compiled for every ball with the default settings (tolerance
//! lifted, so that every ball gives its figure); it prints per ball the moves kept,
//! the lines and segments used, the largest deviation from the show in mm and where
//! (ms), and the compile time, then the extremes over all balls. Options go to the
//! example unchanged: `--rows R --cols C --minutes M --period-s P --row-ms MS
//! --amplitude-mm A --from-rest 1` (every ball the same sine from rest).
//! Nothing is asserted.

use crate::tools;

/// Builds and runs the report.
///
/// # Errors
/// The build or the run failed.
pub fn qprogram_report(args: &[String]) -> Result<(), String> {
    let root = tools::workspace_root();
    let env = tools::Env::discover(&root)?;
    tools::run_command(
        tools::cargo(&env)
            .args([
                "run",
                "--release",
                "--quiet",
                "--package",
                "floatball-shared",
                "--example",
                "qprogram_report",
                "--",
            ])
            .args(args),
    )
}
