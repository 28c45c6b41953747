//! `cargo xtask live-bench [--debug] [--changes N] [--cpu-seconds S] [--seconds S]
//! [--cycles N]`: live input's figures (issues 38 and 47).
//!
//! Runs the bridge test `bridge/tests/live_bench.rs` (a release build unless
//! `--debug`) with `LIVE_BENCH=1`: the real `floatball` binary fed Art-Net by the
//! bench; it prints packet → first motion out per family (p50/p99/max: the first MBOX
//! frame over N changes, default 200, against one frame period + 2 ms; the first
//! UIM2503 row for 100 units at 115200 baud, against the line's floor, and the first
//! MOONS' jog command over eSCL, N / 2 changes each), the bridge's CPU with 10,000
//! simulated MBOX axes and 40 universes × 44 packets/s for S seconds (default 20),
//! and the largest position error against the filtered input over a random-fader
//! run (default 60 s). Nothing about speed is asserted. Then `bridge/tests/live_limits.rs`
//! with `LIVE_LIMITS_CYCLES=N` (default 5): per family, a fader snapped to the bottom
//! of the travel and back N times, and the peak speed and acceleration at the ball
//! (the simulated balls sampled ~10 ms apart) printed against the limits; for MOONS'
//! drives, whose simulation in the bridge carries no clock, the sans-IO rig's figures
//! (`shared/src/scl/drive/tests/live.rs`: every drive twin every millisecond).

use crate::tools;

/// The options.
#[derive(Debug, PartialEq, Eq)]
struct Options {
    debug: bool,
    changes: u64,
    cpu_seconds: u64,
    seconds: u64,
    cycles: u64,
}

const USAGE: &str = "usage: cargo xtask live-bench [--debug] [--changes N] [--cpu-seconds S] \
                     [--seconds S] [--cycles N]";

fn parse_options(args: &[String]) -> Result<Options, String> {
    let mut options = Options {
        debug: false,
        changes: 200,
        cpu_seconds: 20,
        seconds: 60,
        cycles: 5,
    };
    let mut args = args.iter();
    while let Some(flag) = args.next() {
        if flag == "--debug" {
            options.debug = true;
            continue;
        }
        let slot = match flag.as_str() {
            "--changes" => &mut options.changes,
            "--cpu-seconds" => &mut options.cpu_seconds,
            "--seconds" => &mut options.seconds,
            "--cycles" => &mut options.cycles,
            _ => return Err(USAGE.to_owned()),
        };
        *slot = args
            .next()
            .and_then(|value| value.parse().ok())
            .filter(|value| *value > 0)
            .ok_or_else(|| format!("{flag} needs a positive number"))?;
    }
    Ok(options)
}

/// Builds and runs the benchmark.
///
/// # Errors
/// The build or the run failed.
pub fn live_bench(args: &[String]) -> Result<(), String> {
    let options = parse_options(args)?;
    let root = tools::workspace_root();
    let env = tools::Env::discover(&root)?;
    println!(
        "xtask: live input: {} changes to one MBOX box, {} s of 40 universes into 10,000 \
         axes, a {} s random fader",
        options.changes, options.cpu_seconds, options.seconds
    );
    tools::run_command(
        bridge_test(&env, options.debug, "live_bench")
            .env("LIVE_BENCH", "1")
            .env("LIVE_BENCH_CHANGES", options.changes.to_string())
            .env(
                "LIVE_BENCH_UIM2503_CHANGES",
                (options.changes / 2).max(1).to_string(),
            )
            .env(
                "LIVE_BENCH_MOONS_CHANGES",
                (options.changes / 2).max(1).to_string(),
            )
            .env("LIVE_BENCH_CPU_SECONDS", options.cpu_seconds.to_string())
            .env("LIVE_BENCH_ERROR_SECONDS", options.seconds.to_string()),
    )?;
    println!(
        "xtask: the limits at the ball: a fader snapped to either end {} times per family",
        options.cycles
    );
    tools::run_command(
        bridge_test(&env, options.debug, "live_limits")
            .args(["--test-threads", "1"])
            .env("LIVE_LIMITS_CYCLES", options.cycles.to_string()),
    )?;
    // The simulated MOONS' drives in the bridge carry no clock: their peak speed and
    // acceleration at the ball come from the sans-IO rig, which checks every drive
    // twin every millisecond on a line whose timing is modelled byte by byte.
    println!("xtask: MOONS' drives at the ball: the drive twins' rig (every millisecond)");
    let mut rig = tools::cargo(&env);
    rig.arg("test");
    if !options.debug {
        rig.arg("--release");
    }
    tools::run_command(rig.args([
        "--package",
        "floatball-shared",
        "--lib",
        "scl::drive::tests::live",
        "--",
        "--nocapture",
        "--test-threads",
        "1",
    ]))
}

/// `cargo test` of the bridge's test `name` with its output shown, in release unless
/// `debug`; more test arguments may follow.
fn bridge_test(env: &tools::Env, debug: bool, name: &str) -> std::process::Command {
    let mut command = tools::cargo(env);
    command.arg("test");
    if !debug {
        command.arg("--release");
    }
    command
        .args(["--package", "floatball-bridge"])
        .args(["--test", tools::BRIDGE_TESTS, "--"])
        .arg(tools::bridge_module(name))
        .arg("--nocapture");
    command
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options() {
        let strings = |args: &[&str]| args.iter().map(|arg| (*arg).to_owned()).collect::<Vec<_>>();
        assert_eq!(
            parse_options(&[]),
            Ok(Options {
                debug: false,
                changes: 200,
                cpu_seconds: 20,
                seconds: 60,
                cycles: 5
            })
        );
        assert_eq!(
            parse_options(&strings(&[
                "--debug",
                "--changes",
                "50",
                "--seconds",
                "10",
                "--cycles",
                "2"
            ])),
            Ok(Options {
                debug: true,
                changes: 50,
                cpu_seconds: 20,
                seconds: 10,
                cycles: 2
            })
        );
        assert!(parse_options(&strings(&["--changes", "0"])).is_err());
        assert!(parse_options(&strings(&["--fast"])).is_err());
    }
}
