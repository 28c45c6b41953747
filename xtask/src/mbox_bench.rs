//! `cargo xtask mbox-bench [--boxes N] [--seconds S]`: one bridge streaming to many
//! simulated 10-axis MBOX boxes on loopback, with figures.
//!
//! Runs the bridge test `bridge/tests/mbox_bench.rs` in a release build with
//! `MBOX_BENCH_BOXES` = N (default 1000, i.e. 10,000 axes) and `MBOX_BENCH_SECONDS` =
//! S (default 30): the real `floatball` binary plays a show to N twins of
//! `floatball simulate --kind mbox` (a process of their own, one UDP socket a box) at
//! a 20 ms frame period. It prints the bridge's CPU use (utime + stime from
//! `/proc/<pid>/stat`), the frames sent a second, how late the frames left their slot
//! (p50/p99/max, from `GET /api/mbox/timing`), the late frames, the twins' CPU use
//! and the datagrams lost on the way. Nothing about speed is asserted.
//!
//! Each box is a socket in the twins' process: the open-file limit must allow N of
//! them, so the soft limit is raised to the hard one first (`ulimit -n`).

use crate::tools;

/// The options: (boxes, seconds).
fn parse_options(args: &[String]) -> Result<(u32, u32), String> {
    let [boxes, seconds] = tools::parse_counts(
        args,
        [("--boxes", 1000), ("--seconds", 30)],
        "usage: cargo xtask mbox-bench [--boxes N] [--seconds S]",
    )?;
    Ok((boxes, seconds))
}

/// Builds and runs the benchmark.
///
/// # Errors
/// The build or the run failed.
pub fn mbox_bench(args: &[String]) -> Result<(), String> {
    let (boxes, seconds) = parse_options(args)?;
    tools::run_release_bench(
        "mbox_bench",
        &[
            ("MBOX_BENCH_BOXES", boxes.to_string()),
            ("MBOX_BENCH_SECONDS", seconds.to_string()),
        ],
        &format!("{boxes} MBOX boxes × 10 axes at 20 ms for {seconds} s"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_to_a_thousand_boxes_for_thirty_seconds() {
        let strings = |args: &[&str]| args.iter().map(|arg| (*arg).to_owned()).collect::<Vec<_>>();
        assert_eq!(parse_options(&[]), Ok((1000, 30)));
        assert_eq!(
            parse_options(&strings(&["--boxes", "100", "--seconds", "5"])),
            Ok((100, 5))
        );
        assert!(parse_options(&strings(&["--boxes", "0"])).is_err());
        assert!(parse_options(&strings(&["--seconds"])).is_err());
        assert!(parse_options(&strings(&["--fast"])).is_err());
    }
}
