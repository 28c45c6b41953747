//! `cargo xtask stress [--runs N]`: the engine's race and load tests, run many times in
//! a row, with figures.
//!
//! `cargo xtask test` runs each once, short. This runs the e-stop race test
//! (`bridge/tests/estop_race.rs`: Start then e-stop at 0–100 ms on a 9600-baud pty
//! through the real binary, and the stalled-line watchdog) and the stress test
//! (`bridge/tests/stress.rs`: two and four gateways, 100 reading and 20 silent
//! WebSocket clients, e-stops at random moments) `N` times each (default 50), stops at
//! the first failure, and prints how many passed in a row and how long they took.

use std::time::Instant;

use crate::tools;

/// The tests this command repeats: (test target, what it checks).
const TARGETS: [(&str, &str); 2] = [
    (
        "estop_race",
        "Start/e-stop races and the stalled-line watchdog",
    ),
    (
        "stress",
        "2 and 4 gateways under load, e-stops at random moments",
    ),
];

/// Parses `--runs N`.
fn parse_runs(args: &[String]) -> Result<usize, String> {
    match args {
        [] => Ok(50),
        [flag, runs] if flag == "--runs" => runs
            .parse()
            .ok()
            .filter(|runs| *runs > 0)
            .ok_or_else(|| format!("--runs needs a positive number, not {runs:?}")),
        _ => Err("usage: cargo xtask stress [--runs N]".to_owned()),
    }
}

/// Runs the race and stress tests `--runs` times each.
///
/// # Errors
/// The first run that failed, with its number.
pub fn stress(args: &[String]) -> Result<(), String> {
    let runs = parse_runs(args)?;
    let root = tools::workspace_root();
    let env = tools::Env::discover(&root)?;
    let mut build = tools::cargo(&env);
    build.args(["test", "--package", "floatball-bridge", "--no-run"]);
    build.args(["--test", tools::BRIDGE_TESTS]);
    tools::run_command(&mut build)?;
    for (target, what) in TARGETS {
        let started = Instant::now();
        for run in 1..=runs {
            let mut command = tools::cargo(&env);
            command
                .args(["test", "--quiet", "--package", "floatball-bridge"])
                .args(["--test", tools::BRIDGE_TESTS, "--"])
                .arg(tools::bridge_module(target))
                .arg("--nocapture");
            if let Err(error) = tools::run_command(&mut command) {
                return Err(format!(
                    "{target}: run {run} of {runs} failed after {} passed in a row: {error}",
                    run - 1
                ));
            }
        }
        println!(
            "stress: {target} ({what}): {runs} runs passed in a row in {:.1} min",
            started.elapsed().as_secs_f64() / 60.0
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_default_to_fifty_and_must_be_positive() {
        assert_eq!(parse_runs(&[]), Ok(50));
        assert_eq!(parse_runs(&["--runs".into(), "3".into()]), Ok(3));
        assert!(parse_runs(&["--runs".into(), "0".into()]).is_err());
        assert!(parse_runs(&["--fast".into()]).is_err());
    }
}
