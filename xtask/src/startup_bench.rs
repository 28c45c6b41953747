//! `cargo xtask startup-bench [--library-mb N] [--runs R]`: the bridge's start-up with a
//! large library of shows, with figures (issue 36).
//!
//! Runs the bridge test `bridge/tests/startup_bench.rs` in a release build with
//! `STARTUP_BENCH_MB` = N (default 1024: about 370 generated shows of 10 × 10 balls,
//! 2 to 4.5 minutes each) and `STARTUP_BENCH_RUNS` = R (default 5). The library is
//! generated once and kept under the target directory (`tmp/startup-bench/`), so the
//! runs are repeatable. Each run starts the real `floatball` binary on it and prints
//! the median time from the process's start to its first HTTP answer, to the
//! WebSocket's `estop_sent` and to the complete show list, with the show index kept
//! (a normal restart) and removed (rebuilt in the background). Nothing about speed is
//! asserted.

use crate::tools;

/// The options: (library MB, runs).
fn parse_options(args: &[String]) -> Result<(u32, u32), String> {
    let [mb, runs] = tools::parse_counts(
        args,
        [("--library-mb", 1024), ("--runs", 5)],
        "usage: cargo xtask startup-bench [--library-mb N] [--runs R]",
    )?;
    Ok((mb, runs))
}

/// Builds and runs the benchmark.
///
/// # Errors
/// The build or the run failed.
pub fn startup_bench(args: &[String]) -> Result<(), String> {
    let (mb, runs) = parse_options(args)?;
    tools::run_release_bench(
        "startup_bench",
        &[
            ("STARTUP_BENCH_MB", mb.to_string()),
            ("STARTUP_BENCH_RUNS", runs.to_string()),
        ],
        &format!("start-up with a {mb} MB library of shows, {runs} runs"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_to_a_gigabyte_five_times() {
        let strings = |args: &[&str]| args.iter().map(|arg| (*arg).to_owned()).collect::<Vec<_>>();
        assert_eq!(parse_options(&[]), Ok((1024, 5)));
        assert_eq!(
            parse_options(&strings(&["--library-mb", "72", "--runs", "3"])),
            Ok((72, 3))
        );
        assert!(parse_options(&strings(&["--library-mb", "0"])).is_err());
        assert!(parse_options(&strings(&["--runs"])).is_err());
        assert!(parse_options(&strings(&["--fast"])).is_err());
    }
}
