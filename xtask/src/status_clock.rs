//! `cargo xtask status-clock [--runs N]`: the status clock against the units' own, per
//! drive family (issue 34, item 5), with figures.
//!
//! Runs the bridge test `bridge/tests/status_clock.rs` in a release build with
//! `STATUS_CLOCK_RUNS` = N (default 10): the real `floatball` binary plays a 1.2 s
//! show on each family's simulated matrix (UIM2503 at 115200 baud, MBOX at 20 ms,
//! MOONS' drives started by `QX1` and by a trigger's edge) N times, and prints, per
//! family, the offset between every `playing` status's show time and the units' own
//! (p50 / p99 / max), how long after the balls began the state `playing` arrived,
//! the uncertainty of the units' start, and whether the start was announced. Nothing
//! about time is asserted.

use crate::tools;

/// The option: runs a family.
fn parse_options(args: &[String]) -> Result<u32, String> {
    let [runs] = tools::parse_counts(
        args,
        [("--runs", 10)],
        "usage: cargo xtask status-clock [--runs N]",
    )?;
    Ok(runs)
}

/// Builds and runs the benchmark.
///
/// # Errors
/// The build or the run failed.
pub fn status_clock(args: &[String]) -> Result<(), String> {
    let runs = parse_options(args)?;
    tools::run_release_bench(
        "status_clock",
        &[("STATUS_CLOCK_RUNS", runs.to_string())],
        &format!("the status clock against the units', {runs} runs on each family"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_to_ten_runs() {
        let strings = |args: &[&str]| args.iter().map(|arg| (*arg).to_owned()).collect::<Vec<_>>();
        assert_eq!(parse_options(&[]), Ok(10));
        assert_eq!(parse_options(&strings(&["--runs", "3"])), Ok(3));
        assert!(parse_options(&strings(&["--runs", "0"])).is_err());
        assert!(parse_options(&strings(&["--fast"])).is_err());
    }
}
