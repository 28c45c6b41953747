//! `cargo xtask identify-repeat [--repeats N]`: issue 36's check that every Identify
//! answered 202 moves its unit, repeated many times under load.
//!
//! Runs the bridge test `identify_moves_its_ball_every_time_under_load`
//! (`bridge/tests/commission.rs`) with `IDENTIFY_REPEATS` = N (default 200): the real
//! `floatball` binary with 10 simulated gateways (at 9600 and 115200 baud), every core
//! kept busy and the simulator polled without pause; each 202 must be followed by its
//! unit on its way. It prints how long the run took and the median and longest time
//! from the 202 to the move seen. The test suite runs the same test with 30.

use crate::tools;

/// The option: identifies in all.
fn parse_options(args: &[String]) -> Result<u32, String> {
    match args {
        [] => Ok(200),
        [flag, value] if flag == "--repeats" => value
            .parse()
            .ok()
            .filter(|repeats| *repeats > 0)
            .ok_or_else(|| format!("{flag} needs a positive number")),
        _ => Err("usage: cargo xtask identify-repeat [--repeats N]".to_owned()),
    }
}

/// Builds and runs the check.
///
/// # Errors
/// The build failed, or an identify moved nothing.
pub fn identify_repeat(args: &[String]) -> Result<(), String> {
    let repeats = parse_options(args)?;
    let root = tools::workspace_root();
    let env = tools::Env::discover(&root)?;
    println!("xtask: {repeats} identifies on simulated gateways under load");
    tools::run_command(
        tools::cargo(&env)
            .args([
                "test",
                "--package",
                "floatball-bridge",
                "--test",
                tools::BRIDGE_TESTS,
            ])
            .args([
                "commission::identify_moves_its_ball_every_time_under_load",
                "--",
                "--exact",
                "--nocapture",
            ])
            .env("IDENTIFY_REPEATS", repeats.to_string()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_to_two_hundred() {
        let strings = |args: &[&str]| args.iter().map(|arg| (*arg).to_owned()).collect::<Vec<_>>();
        assert_eq!(parse_options(&[]), Ok(200));
        assert_eq!(parse_options(&strings(&["--repeats", "30"])), Ok(30));
        assert!(parse_options(&strings(&["--repeats", "0"])).is_err());
        assert!(parse_options(&strings(&["--repeats"])).is_err());
        assert!(parse_options(&strings(&["--fast"])).is_err());
    }
}
