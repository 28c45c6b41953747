//! `cargo xtask csv-report`: CSV import against the analytic curves it samples, with
//! figures.
//!
//! Runs the example `shared/examples/csv_report.rs` in a release build: sines of
//! several periods and amplitudes, a raised cosine from the top, smooth steps and a
//! damped bounce, sampled at 25, 10 and 5 keyframes a second (positions to 0.001 mm),
//! imported as CSV. It prints a table: per curve and rate the largest position error
//! (mm), the peak speed and acceleration of the imported curve against the analytic
//! ones, whether the analytic curve is within the default limits and whether the CSV is
//! accepted by the upload's validation, and the same figures for the conversion before
//! issue 34 (velocity 0 at every turning point). Nothing is asserted; the test
//! `show::csv::tests::a_sampled_sine_is_kept_and_accepted` asserts the main case.

use crate::tools;

/// Builds and runs the report.
///
/// # Errors
/// The build or the run failed.
pub fn csv_report(args: &[String]) -> Result<(), String> {
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
                "csv_report",
                "--",
            ])
            .args(args),
    )
}
