//! `cargo xtask fuzz`: the readers of untrusted bytes at length, in two parts.
//!
//! 1. **The fuzz targets** (the gateway's instruction reader, the simulated gateway
//!    behind its line, the feedback decoder, the console parser) in an optimised
//!    build: `cargo bench -p floatball-shared --bench fuzz -- --bytes N`. Each target
//!    gets `--bytes N` bytes (10 000 000 unless told) and prints bytes/s and what it
//!    saw; a failed property panics with the seed that reproduces it. The targets are
//!    `shared/tests/fuzz/targets.rs`, which `cargo test` also runs briefly.
//! 2. **The storm with its motion oracle** (issue 52): the bridge test
//!    `bridge/tests/untrusted.rs` at length — the real `floatball` on each family's
//!    simulated matrix, every input of it (OSC, Art-Net, sACN, timecode, the MBOX
//!    host socket, the serial feedback, WebSocket, HTTP) fed random, mutated and
//!    hostile input, failing on any motion, state change, e-stop, panic or stall —
//!    `--storm-seconds S` per family (60 unless told) at `--storm-rate R` datagrams a
//!    second in all (2 000 unless told), the seed `--storm-seed` (the test's own
//!    unless told). It prints the figures: what each reader was sent, what was skipped
//!    as a valid command, the worst pong and HTTP answer, the violations (0). It runs
//!    in the debug build `cargo xtask test` builds (overflow checks and debug
//!    assertions on, which a storm is there to trip); `cargo test` runs its short
//!    version (3 s per family).
//!
//! `--skip-bench` and `--skip-storm` leave a part out. Both parts run even when the
//! first fails; the command fails if either did.

use crate::tools::{self, Env};

/// What `cargo xtask fuzz` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// The arguments passed on to the fuzz bench; `None` to skip it.
    pub bench: Option<Vec<String>>,
    /// The storm; `None` to skip it.
    pub storm: Option<Storm>,
}

/// The storm's length, rate and seed.
#[derive(Debug, Clone, PartialEq)]
pub struct Storm {
    /// Seconds per family.
    pub seconds: f64,
    /// Datagrams a second into one family's UDP readers, in all.
    pub rate_per_s: f64,
    /// The seed; the test's own when `None`.
    pub seed: Option<u64>,
}

impl Storm {
    /// The environment the test reads them from.
    pub fn vars(&self) -> Vec<(&'static str, String)> {
        let mut vars = vec![
            ("FLOATBALL_STORM_SECONDS", self.seconds.to_string()),
            ("FLOATBALL_STORM_RATE", self.rate_per_s.to_string()),
        ];
        if let Some(seed) = self.seed {
            vars.push(("FLOATBALL_STORM_SEED", seed.to_string()));
        }
        vars
    }
}

const USAGE: &str = "usage: cargo xtask fuzz [--bytes N] [--target NAME] [--seed S] \
                     [--storm-seconds S] [--storm-rate R] [--storm-seed S] [--skip-bench] \
                     [--skip-storm]";

/// A positive number of `name`.
fn positive(name: &str, value: &str) -> Result<f64, String> {
    value
        .replace('_', "")
        .parse::<f64>()
        .ok()
        .filter(|number| number.is_finite() && *number > 0.0)
        .ok_or_else(|| format!("{name} {value}: not a number above 0"))
}

/// Parses the options of `cargo xtask fuzz`.
///
/// # Errors
/// An unknown option, or one without its value or with a value that is not a number.
pub fn parse_options(args: &[String]) -> Result<Options, String> {
    let mut bench = vec!["--bytes".to_owned(), "10000000".to_owned()];
    let mut storm = Storm {
        seconds: 60.0,
        rate_per_s: 2_000.0,
        seed: None,
    };
    let (mut skip_bench, mut skip_storm) = (false, false);
    let mut iter = args.iter();
    while let Some(arg) = iter.next() {
        let name = arg.as_str();
        match name {
            "--skip-bench" => skip_bench = true,
            "--skip-storm" => skip_storm = true,
            "--bytes" | "--target" | "--seed" | "--storm-seconds" | "--storm-rate"
            | "--storm-seed" => {
                let value = iter.next().ok_or(format!("{name} needs a value"))?;
                match name {
                    "--storm-seconds" => storm.seconds = positive(name, value)?,
                    "--storm-rate" => storm.rate_per_s = positive(name, value)?,
                    "--storm-seed" => {
                        storm.seed = Some(
                            value
                                .replace('_', "")
                                .parse::<u64>()
                                .map_err(|err| format!("{name} {value}: {err}"))?,
                        );
                    }
                    _ => {
                        if name != "--target" {
                            value
                                .replace('_', "")
                                .parse::<u64>()
                                .map_err(|err| format!("{name} {value}: {err}"))?;
                        }
                        if name == "--bytes" {
                            bench.drain(..2);
                        }
                        bench.extend([name.to_owned(), value.clone()]);
                    }
                }
            }
            other => return Err(format!("unknown option {other}\n{USAGE}")),
        }
    }
    if skip_bench && skip_storm {
        return Err(format!(
            "--skip-bench and --skip-storm leave nothing to run\n{USAGE}"
        ));
    }
    Ok(Options {
        bench: (!skip_bench).then_some(bench),
        storm: (!skip_storm).then_some(storm),
    })
}

/// Runs the fuzz targets, then the storm.
///
/// # Errors
/// Which part failed.
pub fn fuzz(args: &[String]) -> Result<(), String> {
    let options = parse_options(args)?;
    let root = tools::workspace_root();
    let env = Env::discover(&root)?;
    let mut failures = Vec::new();
    if let Some(passed) = &options.bench {
        let ran = tools::run_command(
            tools::cargo(&env)
                .args([
                    "bench",
                    "--package",
                    "floatball-shared",
                    "--bench",
                    "fuzz",
                    "--",
                ])
                .args(passed),
        );
        if let Err(why) = ran {
            failures.push(why);
        }
    }
    if let Some(storm) = &options.storm {
        println!(
            "xtask: the storm: {} s per family at {} datagrams/s in all",
            storm.seconds, storm.rate_per_s
        );
        let mut command = tools::cargo(&env);
        command
            .args([
                "test",
                "--package",
                "floatball-bridge",
                "--test",
                tools::BRIDGE_TESTS,
                "--",
            ])
            .arg(tools::bridge_module("untrusted"))
            .args(["--nocapture", "--test-threads=1"]);
        for (key, value) in storm.vars() {
            command.env(key, value);
        }
        if let Err(why) = tools::run_command(&mut command) {
            failures.push(why);
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(failures.join("; "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(args: &[&str]) -> Vec<String> {
        args.iter().map(|arg| (*arg).to_owned()).collect()
    }

    #[test]
    fn ten_million_bytes_and_a_minute_of_storm_unless_told() {
        let options = parse_options(&[]).unwrap();
        assert_eq!(options.bench, Some(strings(&["--bytes", "10000000"])));
        assert_eq!(
            options.storm,
            Some(Storm {
                seconds: 60.0,
                rate_per_s: 2_000.0,
                seed: None
            })
        );
        let options =
            parse_options(&strings(&["--bytes", "1_000", "--target", "gateway"])).unwrap();
        assert_eq!(
            options.bench,
            Some(strings(&["--bytes", "1_000", "--target", "gateway"]))
        );
    }

    #[test]
    fn the_storm_takes_its_length_rate_and_seed() {
        let options = parse_options(&strings(&[
            "--storm-seconds",
            "20",
            "--storm-rate",
            "1_500",
            "--storm-seed",
            "7",
            "--skip-bench",
        ]))
        .unwrap();
        assert_eq!(options.bench, None);
        let storm = options.storm.unwrap();
        assert_eq!(
            storm,
            Storm {
                seconds: 20.0,
                rate_per_s: 1_500.0,
                seed: Some(7)
            }
        );
        assert_eq!(
            storm.vars(),
            vec![
                ("FLOATBALL_STORM_SECONDS", "20".to_owned()),
                ("FLOATBALL_STORM_RATE", "1500".to_owned()),
                ("FLOATBALL_STORM_SEED", "7".to_owned()),
            ]
        );
        let options = parse_options(&strings(&["--skip-storm", "--storm-seconds", "0.5"])).unwrap();
        assert_eq!(options.storm, None);
        assert!(options.bench.is_some());
    }

    #[test]
    fn refuses_what_it_does_not_know() {
        assert!(parse_options(&strings(&["--bytes"])).is_err());
        assert!(parse_options(&strings(&["--bytes", "many"])).is_err());
        assert!(parse_options(&strings(&["--frobnicate"])).is_err());
        assert!(parse_options(&strings(&["--storm-seconds"])).is_err());
        assert!(parse_options(&strings(&["--storm-seconds", "0"])).is_err());
        assert!(parse_options(&strings(&["--storm-rate", "-5"])).is_err());
        assert!(parse_options(&strings(&["--storm-rate", "inf"])).is_err());
        assert!(parse_options(&strings(&["--storm-seed", "1.5"])).is_err());
        assert!(parse_options(&strings(&["--skip-bench", "--skip-storm"])).is_err());
    }
}
