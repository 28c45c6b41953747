//! `cargo xtask timecode-bench [--seconds N]`: the timecode chase's figures.
//!
//! Runs the bridge test `bridge/tests/timecode_bench.rs` in a release build with
//! `TIMECODE_BENCH_SECONDS` = N (default 300, a 5-minute show): the real `floatball`
//! binary on each family's simulated matrix chasing Art-Net timecode; it prints the
//! show − timecode error while chasing (p50/p99/max) and the drift per family, the
//! lead from the timecode cue to the start, and the time from a locate to playing
//! again at the new point on a 10 × 10 UIM2503 matrix at 115200 baud. Nothing about
//! speed is asserted. `--fast-ppm PPM` runs the timecode's clock that much fast (a
//! drift to correct), `--uncorrected` chases without correcting it (`correct_drift =
//! false`), `--no-locate` skips the 10 × 10 locate, `--debug` runs a debug build
//! (`--release`, the default, a release one).

use crate::tools;

/// The options: the show's length, seconds; how fast the sender's clock runs, ppm;
/// whether the drift is corrected; whether in a release build.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Options {
    seconds: u64,
    fast_ppm: u64,
    uncorrected: bool,
    release: bool,
    no_locate: bool,
}

const USAGE: &str = "usage: cargo xtask timecode-bench [--seconds N] [--fast-ppm PPM] \
                     [--uncorrected] [--no-locate] [--release | --debug]";

fn parse_options(args: &[String]) -> Result<Options, String> {
    let mut options = Options {
        seconds: 300,
        fast_ppm: 0,
        uncorrected: false,
        release: true,
        no_locate: false,
    };
    let mut args = args.iter();
    while let Some(flag) = args.next() {
        match flag.as_str() {
            "--seconds" => {
                options.seconds = args
                    .next()
                    .and_then(|value| value.parse().ok())
                    .filter(|seconds| *seconds >= 10)
                    .ok_or_else(|| format!("{flag} needs a number of seconds, at least 10"))?;
            }
            "--fast-ppm" => {
                options.fast_ppm = args
                    .next()
                    .and_then(|value| value.parse().ok())
                    .filter(|ppm| *ppm <= 100_000)
                    .ok_or_else(|| format!("{flag} needs parts per million, at most 100000"))?;
            }
            "--uncorrected" => options.uncorrected = true,
            "--no-locate" => options.no_locate = true,
            "--release" => options.release = true,
            "--debug" => options.release = false,
            _ => return Err(USAGE.to_owned()),
        }
    }
    Ok(options)
}

/// Builds and runs the benchmark.
///
/// # Errors
/// The build or the run failed.
pub fn timecode_bench(args: &[String]) -> Result<(), String> {
    let options = parse_options(args)?;
    let mut vars = vec![("TIMECODE_BENCH_SECONDS", options.seconds.to_string())];
    if options.fast_ppm > 0 {
        vars.push(("TIMECODE_BENCH_FAST_PPM", options.fast_ppm.to_string()));
    }
    if options.uncorrected {
        vars.push(("TIMECODE_BENCH_UNCORRECTED", "1".to_owned()));
    }
    if options.no_locate {
        vars.push(("TIMECODE_BENCH_NO_LOCATE", "1".to_owned()));
    }
    let banner = format!(
        "chasing Art-Net timecode for {} s on each family ({} ppm fast, drift {}corrected), \
         then locates",
        options.seconds,
        options.fast_ppm,
        if options.uncorrected { "un" } else { "" }
    );
    if options.release {
        return tools::run_release_bench("timecode_bench", &vars, &banner);
    }
    let root = tools::workspace_root();
    let env = tools::Env::discover(&root)?;
    println!("xtask: {banner} (debug build)");
    let mut command = tools::cargo(&env);
    command
        .args(["test", "--package", "floatball-bridge"])
        .args(["--test", tools::BRIDGE_TESTS, "--"])
        .arg(tools::bridge_module("timecode_bench"))
        .arg("--nocapture");
    for (key, value) in vars {
        command.env(key, value);
    }
    tools::run_command(&mut command)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_to_five_minutes_in_a_release_build() {
        let strings = |args: &[&str]| args.iter().map(|arg| (*arg).to_owned()).collect::<Vec<_>>();
        let defaults = parse_options(&[]).unwrap();
        assert_eq!(defaults.seconds, 300);
        assert!(defaults.release && !defaults.uncorrected && defaults.fast_ppm == 0);
        let options = parse_options(&strings(&[
            "--seconds",
            "60",
            "--fast-ppm",
            "5000",
            "--uncorrected",
            "--debug",
        ]))
        .unwrap();
        assert_eq!((options.seconds, options.fast_ppm), (60, 5_000));
        assert!(options.uncorrected && !options.release);
        assert!(parse_options(&strings(&["--seconds", "5"])).is_err());
        assert!(parse_options(&strings(&["--fast"])).is_err());
    }
}
