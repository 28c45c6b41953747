//! `cargo xtask scale-bench [--gateways N] [--seconds S]`: one bridge playing a ripple
//! to many simulated UIM2503 gateways of 100 units over `tcp://`, with figures.
//!
//! Runs the bridge test `bridge/tests/scale_bench.rs` in a release build with
//! `SCALE_BENCH_GATEWAYS` = N (default 100, i.e. a 100 × 100 grid of 10,000 balls) and
//! `SCALE_BENCH_SECONDS` = S (default 60): the real `floatball` binary plays the show
//! to `floatball simulate --listen` (a process of its own, one TCP port a gateway at
//! 115200 baud). It prints the planning time, the preload time, the start skew across
//! the gateways (p50/p99/spread of the times the start's last byte reached each one),
//! the bridge's CPU use while streaming (utime + stime from `/proc/<pid>/stat`), its
//! peak RSS (`VmHWM`), the status messages' size and rate, the lowest water level and
//! the underruns. It asserts what the normal test run asserts (the show plays to its
//! end, no underrun, every gateway's start received, the e-stop sent to every one),
//! not the figures' goals: those are read (docs/scaling.md).
//!
//! Each gateway is a socket on each side: the open-file limit must allow 2 N of them,
//! so the soft limit is raised to the hard one first (`ulimit -n`).

use crate::tools;

/// The options: (gateways, seconds).
fn parse_options(args: &[String]) -> Result<(u32, u32), String> {
    let [gateways, seconds] = tools::parse_counts(
        args,
        [("--gateways", 100), ("--seconds", 60)],
        "usage: cargo xtask scale-bench [--gateways N] [--seconds S]",
    )?;
    Ok((gateways, seconds))
}

/// Builds and runs the benchmark.
///
/// # Errors
/// The build or the run failed.
pub fn scale_bench(args: &[String]) -> Result<(), String> {
    let (gateways, seconds) = parse_options(args)?;
    tools::run_release_bench(
        "scale_bench",
        &[
            ("SCALE_BENCH_GATEWAYS", gateways.to_string()),
            ("SCALE_BENCH_SECONDS", seconds.to_string()),
        ],
        &format!(
            "{gateways} UIM2503 gateways × 100 units over tcp:// at 115200 baud, a {seconds} s ripple"
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_to_a_hundred_gateways_for_a_minute() {
        let strings = |args: &[&str]| args.iter().map(|arg| (*arg).to_owned()).collect::<Vec<_>>();
        assert_eq!(parse_options(&[]), Ok((100, 60)));
        assert_eq!(
            parse_options(&strings(&["--gateways", "10", "--seconds", "5"])),
            Ok((10, 5))
        );
        assert!(parse_options(&strings(&["--gateways", "0"])).is_err());
        assert!(parse_options(&strings(&["--seconds"])).is_err());
        assert!(parse_options(&strings(&["--fast"])).is_err());
    }
}
