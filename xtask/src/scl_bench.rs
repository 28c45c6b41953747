//! `cargo xtask scl-bench [--presses N]`: the SCL e-stop's latency, with figures.
//!
//! Runs the bridge test `bridge/tests/scl_bench.rs` in a release build with
//! `SCL_BENCH_PRESSES` = N (default 50): the real `floatball` binary with 8 MOONS'
//! drive twins polled every 20 ms, on an RS-485 line at 9600 and at 115200 baud (a
//! pseudo-terminal timed as a UART) and over loopback UDP (eSCL); it prints the median
//! and the maximum time from the WebSocket `estop` to the first byte of the first `SK`
//! on the wire. Nothing about speed is asserted.

use crate::tools;

/// The option: presses per line.
fn parse_options(args: &[String]) -> Result<u32, String> {
    match args {
        [] => Ok(50),
        [flag, value] if flag == "--presses" => value
            .parse()
            .ok()
            .filter(|presses| *presses > 0)
            .ok_or_else(|| format!("{flag} needs a positive number")),
        _ => Err("usage: cargo xtask scl-bench [--presses N]".to_owned()),
    }
}

/// Builds and runs the benchmark.
///
/// # Errors
/// The build or the run failed.
pub fn scl_bench(args: &[String]) -> Result<(), String> {
    let presses = parse_options(args)?;
    let root = tools::workspace_root();
    let env = tools::Env::discover(&root)?;
    println!("xtask: {presses} e-stops on each SCL line (9600, 115200 baud, eSCL)");
    tools::run_command(
        tools::cargo(&env)
            .args(["test", "--release", "--package", "floatball-bridge"])
            .args(["--test", tools::BRIDGE_TESTS, "--"])
            .arg(tools::bridge_module("scl_bench"))
            .arg("--nocapture")
            .env("SCL_BENCH_PRESSES", presses.to_string()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_to_fifty_presses() {
        let strings = |args: &[&str]| args.iter().map(|arg| (*arg).to_owned()).collect::<Vec<_>>();
        assert_eq!(parse_options(&[]), Ok(50));
        assert_eq!(parse_options(&strings(&["--presses", "10"])), Ok(10));
        assert!(parse_options(&strings(&["--presses", "0"])).is_err());
        assert!(parse_options(&strings(&["--presses"])).is_err());
        assert!(parse_options(&strings(&["--fast"])).is_err());
    }
}
