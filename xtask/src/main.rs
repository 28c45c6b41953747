//! `cargo xtask run` and `cargo xtask test`: the two commands a new machine needs.
//!
//! Both install what is missing first (see [`tools`]), saying what and why, then do
//! their work with plain `cargo` commands that are printed before they run, so anyone
//! can repeat a single step by hand.
//!
//! # Layout
//! - [`tools`]: finding and installing the toolchain pieces (wasm32 target,
//!   wasm-bindgen-cli, wasm-pack, wasm-opt, Chromium and ChromeDriver).
//! - [`app`]: building the web app into `static/pkg/` (hashed names, wasm-opt,
//!   brotli and gzip copies, the page that loads them).
//! - [`stages`]: the test stages and their summary.
//! - [`side_by_side`]: a stage's test binaries run two (or more) at a time.
//! - [`leftovers`]: what a test stage left running, named, killed and failed.
//! - [`fuzz`]: `cargo xtask fuzz`, the fuzz targets and the storm with its motion
//!   oracle at length, with figures.
//! - [`stress`]: the engine's race and load tests, many times in a row.
//! - [`mbox_bench`]: one bridge streaming to many simulated MBOX boxes, with figures.
//! - [`scale_bench`]: one bridge playing to 100 UIM2503 gateways over TCP, with figures.
//! - [`qprogram_report`]: the Q program compiler on a 10-minute show, with figures.
//! - [`csv_report`]: CSV import against the analytic curves it samples, with figures.
//! - [`scl_bench`]: the SCL e-stop's latency on RS-485 lines and eSCL, with figures.
//! - [`identify_repeat`]: Identify repeated on simulated gateways under load; every
//!   202 must move its unit (issue 36).
//! - [`create_bench`]: the Create page's cost of one change in the app as served,
//!   with figures.
//! - [`load_bench`]: the release app's compressed sizes and its cold load time in
//!   Chromium on throttled links, with figures.
//! - [`startup_bench`]: the bridge's start-up with a large library of shows, with
//!   figures.
//! - [`timecode_bench`]: the timecode chase on each family, with figures.
//! - [`live_bench`]: live input's latency, CPU and position error, with figures.

mod app;
mod create_bench;
mod csv_report;
mod fuzz;
mod identify_repeat;
mod leftovers;
mod live_bench;
mod load_bench;
mod mbox_bench;
mod qprogram_report;
mod scale_bench;
mod scl_bench;
mod side_by_side;
mod stages;
mod startup_bench;
mod status_clock;
mod stress;
mod timecode_bench;
mod tools;

use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "\
usage: cargo xtask <command> [options]

commands:
  run    build the web app and start the bridge with a simulated matrix
         options: --listen ADDR (default 0.0.0.0:8080)  --data-dir DIR (default ./data)
                  anything after `--` is passed to `floatball` unchanged
  build  build the web app into static/pkg/ (hashed names, .br/.gz copies, the page)
         options: --test (a quick dev build for looking at a change: no wasm-opt)
  test   install what is missing, then run every check and test
         options: --only WORDS (only the stages whose name contains WORDS, e.g.
                  `--only 'native tests'`; for repeating one stage by hand)
  fuzz   run the fuzz targets (readers of untrusted bytes) in an optimised build,
         then the storm with its motion oracle: every input of a real bridge on each
         family's simulated matrix, with figures
         options: --bytes N (per target, default 10000000)  --target NAME  --seed S
                  --storm-seconds S (per family, default 60)  --storm-rate R
                  (datagrams/s in all, default 2000)  --storm-seed S
                  --skip-bench  --skip-storm
  stress run the e-stop race and load tests many times in a row, with figures
         options: --runs N (default 50)
  mbox-bench  stream a show to simulated MBOX boxes on loopback at 20 ms; print the
         bridge's CPU use, frames/s, send lateness p50/p99 and late frames
         options: --boxes N (default 1000)  --seconds S (default 30)
  scale-bench  play a 100 x 100 ripple to simulated UIM2503 gateways over tcp://;
         print planning and preload time, start skew, bridge CPU and RSS, status
         size and rate, lowest water level and underruns
         options: --gateways N (default 100)  --seconds S (default 60)
  qprogram-report  compile a 10-minute demo wave to MOONS' Q programs for every ball;
         print moves kept, lines/segments, max deviation mm and where, compile ms
         options: --rows R --cols C (default 10 x 10)  --minutes M (default 10)
                  --period-s P (default 4)  --row-ms MS (default 200)
  csv-report  sample analytic curves (sines, a smooth step, a damped bounce) at 25, 10
         and 5 keyframes/s, import them as CSV; print the largest position error, peak
         speed and acceleration against the analytic ones, and whether the analytic
         curve is within the limits and the CSV accepted
  scl-bench  press the e-stop on 8 simulated MOONS' drives polled every 20 ms: RS-485
         at 9600 and 115200 baud, and eSCL; print WebSocket -> first SK byte median/max
         options: --presses N (default 50)
  identify-repeat  identify simulated units over and over with every core busy;
         fail on a 202 whose unit did not move (issue 36); print the run time and
         202 -> move seen median/max
         options: --repeats N (default 200)
  load-bench  build the release app; print the raw/gzip/brotli sizes of its wasm, js
         and css, and the median time to a usable app on cold loads in headless
         Chromium throttled to 20 Mbit/s 30 ms and 9 Mbit/s 60 ms
         options: --runs N (default 5)  --no-build (measure what static/pkg/ holds)
                  --host IP (default 127.0.0.1; Chromium offers brotli to loopback
                  and https only, so a LAN address shows the gzip case)
  create-bench  one change of a parameter on the Create page at 10 x 10 and 100 x 100,
         in the app as served (wasm-release) in headless Chromium; print the median
         and largest time to the new picture, and generating, handing to the stage
         and the limit check after it
  startup-bench  start the release bridge on a generated library of shows (kept under
         target/tmp/startup-bench/); print the median time to the first HTTP answer,
         to the WebSocket's estop_sent and to the complete show list, with the show
         index kept and removed
         options: --library-mb N (default 1024)  --runs R (default 5)
  status-clock  play a short show on each family's simulated matrix (UIM2503, MBOX,
         MOONS' by QX1 and by trigger); print the offset of the status's show time
         from the units' own p50/p99/max and how late `playing` arrived
         options: --runs N (default 10)
  timecode-bench  chase Art-Net timecode on each family's simulated matrix; print
         show - timecode p50/p99/max and the drift, the lead from the cue to the start,
         and locate -> playing again on a 10 x 10 UIM2503 matrix at 115200 baud
         options: --seconds N (default 300), --fast-ppm PPM (the timecode's clock that
         much fast), --uncorrected (correct_drift = false), --no-locate,
         --release (default) or --debug
  live-bench  live input through the release bridge: Art-Net packet -> first motion
         out p50/p99/max (MBOX frame, UIM2503 row at 115200 baud for 100 units, MOONS'
         jog command over eSCL), the bridge's CPU with 10,000 simulated MBOX axes
         and 40 universes x 44 packets/s, the largest position error against the
         filtered input over a random fader; then per family a fader snapped to
         either end --cycles N times (default 5): the peak speed and acceleration at
         the ball against the limits
         options: --debug  --changes N (MBOX; UIM2503 and MOONS' N/2; default 200)
                  --cpu-seconds S (default 20)
                  --seconds S (default 60)
";

fn main() -> ExitCode {
    // SAFETY: first thing in `main`, before any thread is started.
    unsafe { leftovers::mark_this_run() };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("run") => run(&args[1..]),
        Some("build") => build(&args[1..]),
        Some("test") => stages::test(&args[1..]),
        Some("fuzz") => fuzz::fuzz(&args[1..]),
        Some("stress") => stress::stress(&args[1..]),
        Some("mbox-bench") => mbox_bench::mbox_bench(&args[1..]),
        Some("scale-bench") => scale_bench::scale_bench(&args[1..]),
        Some("qprogram-report") => qprogram_report::qprogram_report(&args[1..]),
        Some("csv-report") => csv_report::csv_report(&args[1..]),
        Some("scl-bench") => scl_bench::scl_bench(&args[1..]),
        Some("identify-repeat") => identify_repeat::identify_repeat(&args[1..]),
        Some("load-bench") => load_bench::load_bench(&args[1..]),
        Some("create-bench") => create_bench::create_bench(&args[1..]),
        Some("startup-bench") => startup_bench::startup_bench(&args[1..]),
        Some("status-clock") => status_clock::status_clock(&args[1..]),
        Some("timecode-bench") => timecode_bench::timecode_bench(&args[1..]),
        Some("live-bench") => live_bench::live_bench(&args[1..]),
        Some("-h" | "--help" | "help") => {
            print!("{USAGE}");
            Ok(())
        }
        _ => Err(format!("unknown command\n\n{USAGE}")),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("xtask: {message}");
            ExitCode::FAILURE
        }
    }
}

/// Options of `cargo xtask run`.
#[derive(Debug, PartialEq, Eq)]
struct RunOptions {
    listen: String,
    data_dir: String,
    passthrough: Vec<String>,
}

fn parse_run_options(args: &[String]) -> Result<RunOptions, String> {
    let mut options = RunOptions {
        listen: "0.0.0.0:8080".to_owned(),
        data_dir: "data".to_owned(),
        passthrough: Vec::new(),
    };
    let mut iter = args.iter();
    while let Some(arg) = iter.next() {
        match arg.as_str() {
            "--listen" => {
                options.listen = iter.next().ok_or("--listen needs an address")?.clone();
            }
            "--data-dir" => {
                options.data_dir = iter.next().ok_or("--data-dir needs a directory")?.clone();
            }
            "--" => {
                options.passthrough = iter.cloned().collect();
                break;
            }
            other => return Err(format!("unknown option {other}\n\n{USAGE}")),
        }
    }
    Ok(options)
}

fn run(args: &[String]) -> Result<(), String> {
    let options = parse_run_options(args)?;
    let root = tools::workspace_root();
    let env = tools::Env::discover(&root)?;
    tools::ensure_wasm_target(&env)?;
    tools::ensure_wasm_bindgen_cli(&env)?;
    app::build_web(&env, app::Build::Release)?;
    let port = options.listen.rsplit(':').next().unwrap_or("8080");
    println!("xtask: starting floatball; open http://localhost:{port} (Ctrl-C stops it)");
    let mut command = tools::cargo(&env);
    command
        .args([
            "run",
            "--release",
            "--package",
            "floatball-bridge",
            "--bin",
            "floatball",
            "--",
        ])
        .args(["--listen", &options.listen])
        .args(["--data-dir", &options.data_dir])
        .args(["--static-dir", &path_string(root.join("static"))])
        .args(&options.passthrough);
    tools::run_command(&mut command)
}

/// `cargo xtask build [--test]`: the web app alone, as `run` and the tests build it (or a quick dev build).
fn build(args: &[String]) -> Result<(), String> {
    let build = match args {
        [] => app::Build::Release,
        [flag] if flag == "--test" => app::Build::Test,
        _ => return Err(format!("unknown options {args:?}\n\n{USAGE}")),
    };
    let env = tools::Env::discover(&tools::workspace_root())?;
    tools::ensure_wasm_target(&env)?;
    tools::ensure_wasm_bindgen_cli(&env)?;
    app::build_web(&env, build)
}

fn path_string(path: PathBuf) -> String {
    path.to_string_lossy().into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(args: &[&str]) -> Vec<String> {
        args.iter().map(|arg| (*arg).to_owned()).collect()
    }

    #[test]
    fn run_defaults_to_port_8080_and_data() {
        let options = parse_run_options(&[]).unwrap();
        assert_eq!(options.listen, "0.0.0.0:8080");
        assert_eq!(options.data_dir, "data");
    }

    #[test]
    fn run_takes_listen_data_dir_and_passthrough() {
        let options = parse_run_options(&strings(&[
            "--listen",
            "127.0.0.1:9000",
            "--data-dir",
            "/tmp/x",
            "--",
            "--gateway",
            "sim",
        ]))
        .unwrap();
        assert_eq!(options.listen, "127.0.0.1:9000");
        assert_eq!(options.data_dir, "/tmp/x");
        assert_eq!(options.passthrough, strings(&["--gateway", "sim"]));
    }

    #[test]
    fn run_refuses_unknown_options() {
        assert!(parse_run_options(&strings(&["--frobnicate"])).is_err());
        assert!(parse_run_options(&strings(&["--listen"])).is_err());
    }
}
