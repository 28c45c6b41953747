//! `cargo xtask timecode-bench [--seconds N]`: the timecode chase's figures.
//!
//! Runs the bridge test `bridge/tests/timecode_bench.rs` in a release build with
//! `TIMECODE_BENCH_SECONDS` = N (default 300, a 5-minute show): the real `floatball`
//! binary on each family's simulated matrix chasing Art-Net timecode; it prints the
//! show − timecode error while chasing (p50/p99/max) and the drift per family, the
//! lead from the timecode cue to the start, and the time from a locate to playing
//! again at the new point on a 10 × 10 UIM2503 matrix at 115200 baud. Nothing about
//! speed is asserted.

use crate::tools;

/// The option: the show's length, seconds.
fn parse_options(args: &[String]) -> Result<u64, String> {
    match args {
        [] => Ok(300),
        [flag, value] if flag == "--seconds" => value
            .parse()
            .ok()
            .filter(|seconds| *seconds >= 10)
            .ok_or_else(|| format!("{flag} needs a number of seconds, at least 10")),
        _ => Err("usage: cargo xtask timecode-bench [--seconds N]".to_owned()),
    }
}

/// Builds and runs the benchmark.
///
/// # Errors
/// The build or the run failed.
pub fn timecode_bench(args: &[String]) -> Result<(), String> {
    let seconds = parse_options(args)?;
    let root = tools::workspace_root();
    let env = tools::Env::discover(&root)?;
    println!("xtask: chasing Art-Net timecode for {seconds} s on each family, then locates");
    tools::run_command(
        tools::cargo(&env)
            .args(["test", "--release", "--package", "floatball-bridge"])
            .args(["--test", "timecode_bench", "--", "--nocapture"])
            .env("TIMECODE_BENCH_SECONDS", seconds.to_string()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_to_five_minutes() {
        let strings = |args: &[&str]| args.iter().map(|arg| (*arg).to_owned()).collect::<Vec<_>>();
        assert_eq!(parse_options(&[]), Ok(300));
        assert_eq!(parse_options(&strings(&["--seconds", "60"])), Ok(60));
        assert!(parse_options(&strings(&["--seconds", "5"])).is_err());
        assert!(parse_options(&strings(&["--fast"])).is_err());
    }
}
