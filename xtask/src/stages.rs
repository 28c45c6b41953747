//! `cargo xtask test`: every check and test, one stage at a time, with a one-line
//! summary per stage and a final `N passed, N failed` line.
//!
//! Stages keep going after a failure so one run shows everything that is wrong; the
//! command fails if any stage failed.
//!
//! One stage runs its parts side by side: the release app's build spends minutes on
//! one core (fat LTO, then `wasm-opt`), so it runs in the background (its output
//! printed when the stage ends) while the shared crate's wasm32 tests, the web app's
//! tests in Chromium and the end-to-end tests' build take turns on the other; the
//! summary gives each part's time under the stage's.
//!
//! The stages that start processes (the native, web and end-to-end tests) fail if
//! any they started still runs when they end, and kill it (see [`leftovers`]); the
//! test stages end with their slowest test binaries.

use std::ffi::OsString;
use std::sync::{Mutex, PoisonError};
use std::time::Instant;

use crate::leftovers;
use crate::side_by_side;
use crate::tools::{self, Env};

/// The native test binaries: those whose figures or deadlines need the machine to
/// themselves run alone; the rest two (or more) at a time, longest first (seconds
/// from a CI run).
const NATIVE: side_by_side::Plan = side_by_side::Plan {
    solo: &[
        "estop_race",
        "status_clock",
        "stress",
        "scale_bench",
        "mbox_bench",
        "scl_bench",
        "startup_bench",
        "live_bench",
        "login_load",
        "ws_flood",
        // Measures the simulated line's throughput against the baud rate.
        "link_sim",
        // Chases timecode in step (and runs olad on Art-Net's and OLA's fixed ports).
        "timecode",
        // Live input from olad's Art-Net and sACN (fixed ports 6454 and 5568; so
        // does `live_mode`, which no other test beside it uses).
        "live",
        // The bridge's unit tests: the SCL line's e-stop within 20 ms of the press.
        "floatball_bridge",
        // The storm (issue 52): floods every input of a bridge and holds a pong and
        // an answer to 2 s; beside another binary its load would slow that one's
        // deadlines, and the other's its own.
        "untrusted",
    ],
    seconds: &[
        ("live_mode", 33),
        ("playback", 23),
        ("live_limits", 23),
        ("arming", 19),
        ("start_from", 15),
        ("commission", 15),
        ("mbox", 14),
        ("ser2net", 13),
        ("hardening", 11),
        ("greeting", 11),
        ("link_net", 10),
        ("link_serial", 9),
        ("installation", 6),
        ("scl", 5),
        ("scl_golden", 5),
        ("simulate", 5),
        ("link_sim", 4),
        ("live", 4),
    ],
    doc_tests: true,
    by_module: &["integration"],
};

/// The end-to-end test binaries (each a bridge and a browser), longest first.
const END_TO_END: side_by_side::Plan = side_by_side::Plan {
    solo: &[],
    seconds: &[
        ("create", 45),
        ("screens", 42),
        ("operator_mbox", 39),
        ("controls", 28),
        ("commission", 24),
        ("operator_scl", 22),
        ("operator", 17),
        ("files", 14),
        ("installation", 10),
        ("language", 8),
    ],
    doc_tests: false,
    by_module: &["end_to_end"],
};

/// How many characters of a failed stage's reason the summary repeats.
const ERROR_SHOWN_CHARS: usize = 1500;

/// `cargo test`'s arguments for the end-to-end tests.
const END_TO_END_ARGS: [&str; 2] = ["--package", "floatball-e2e"];

/// The environment of the end-to-end tests' build and binaries.
fn end_to_end_envs(env: &Env) -> Vec<(&'static str, OsString)> {
    vec![
        (
            "FLOATBALL_BIN",
            env.target_dir.join("debug").join("floatball").into(),
        ),
        ("FLOATBALL_STATIC_DIR", env.root.join("static").into()),
        ("CHROMEDRIVER", tools::CHROMEDRIVER.into()),
    ]
}

/// The stage that runs the wasm32 tests, the browser tests and the end-to-end tests'
/// build beside the release app's build.
const SIDE_BY_SIDE_STAGE: &str = "wasm32 and browser tests beside the release app";

/// The part of [`SIDE_BY_SIDE_STAGE`] that runs in the background.
const RELEASE_APP_PART: &str = "build the app (release)";

/// How many lines of a failed background build's output its error repeats.
const FAILED_LOG_LINES: usize = 30;

/// One of the things a stage runs side by side, as it ended.
struct Part {
    name: &'static str,
    seconds: f64,
    error: Option<String>,
}

impl Part {
    fn failed(name: &'static str, error: &str) -> Part {
        Part {
            name,
            seconds: 0.0,
            error: Some(error.to_owned()),
        }
    }

    /// `ok   <name> (<s> s)` or `FAIL <name> (<s> s)`.
    fn line(&self) -> String {
        let mark = if self.error.is_none() { "ok  " } else { "FAIL" };
        format!("{mark} {} ({:.1} s)", self.name, self.seconds)
    }
}

/// Runs `body` as the part `name` of a stage, timed, with a heading and an end line
/// like a stage's.
fn part(name: &'static str, body: impl FnOnce() -> Result<(), String>) -> Part {
    println!("\nxtask: --> {name}");
    let started = Instant::now();
    let error = body().err();
    let ended = Part {
        name,
        seconds: started.elapsed().as_secs_f64(),
        error,
    };
    println!("xtask: {}", ended.line());
    ended
}

/// Builds the release app (`cargo xtask build`, in a process of its own) with its
/// output into `log` instead of the terminal, where the tests beside it write theirs.
///
/// # Errors
/// The build failed (with the end of its output), or could not start.
fn release_app_in_background(env: &Env, log: &mut String) -> Result<(), String> {
    let exe = std::env::current_exe().map_err(|err| format!("cannot find the xtask: {err}"))?;
    let mut command = tools::program(env, &exe.to_string_lossy());
    command.arg("build");
    println!(
        "xtask: $ {} (in the background; its output follows the other parts')",
        tools::describe(&command)
    );
    let output = command
        .output()
        .map_err(|err| format!("cannot start `{}`: {err}", tools::describe(&command)))?;
    log.push_str(&String::from_utf8_lossy(&output.stdout));
    log.push_str(&String::from_utf8_lossy(&output.stderr));
    if output.status.success() {
        Ok(())
    } else {
        let lines: Vec<&str> = log.lines().collect();
        let tail = lines[lines.len().saturating_sub(FAILED_LOG_LINES)..].join("\n");
        Err(format!(
            "`{}` failed ({}); the end of its output:\n{tail}",
            tools::describe(&command),
            output.status
        ))
    }
}

/// One line of the summary.
struct Outcome {
    name: &'static str,
    seconds: f64,
    error: Option<String>,
}

/// Runs every stage (or, with `--only WORDS`, those whose name contains the words)
/// and prints the summary.
pub fn test(args: &[String]) -> Result<(), String> {
    let only = match args {
        [] => None,
        [flag, words] if flag == "--only" => Some(words.clone()),
        _ => return Err(format!("unknown options {args:?}: see `cargo xtask`")),
    };
    let root = tools::workspace_root();
    let env = Env::discover(&root)?;
    println!(
        "xtask: disk: {} (target directory {})",
        tools::free_space(&env.target_dir),
        env.target_dir.display()
    );
    let mut outcomes = Vec::new();
    // The parts of the stage that runs things side by side, for the summary.
    let parts: Mutex<Vec<Part>> = Mutex::new(Vec::new());
    let mut stage = |name: &'static str, body: &dyn Fn(&Env) -> Result<(), String>| {
        if only
            .as_ref()
            .is_some_and(|words| !name.contains(words.as_str()))
        {
            return;
        }
        println!("\nxtask: ==> {name}");
        let started = Instant::now();
        let error = body(&env).err();
        let seconds = started.elapsed().as_secs_f64();
        match &error {
            None => println!("xtask: ok   {name} ({seconds:.1} s)"),
            Some(message) => println!("xtask: FAIL {name} ({seconds:.1} s): {message}"),
        }
        outcomes.push(Outcome {
            name,
            seconds,
            error,
        });
    };

    stage("install missing tools", &install_tools);
    stage("cargo fmt --check", &|env| {
        tools::run_command(tools::cargo(env).args(["fmt", "--all", "--check"]))
    });
    stage("clippy (native)", &|env| {
        tools::run_command(tools::cargo(env).args([
            "clippy",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ]))
    });
    stage("clippy (wasm32: shared, web)", &|env| {
        tools::run_command(tools::cargo(env).args([
            "clippy",
            "--package",
            "floatball-shared",
            "--package",
            "floatball-web",
            "--target",
            "wasm32-unknown-unknown",
            "--lib",
            "--tests",
            "--",
            "-D",
            "warnings",
        ]))
    });
    stage("native tests", &|env| {
        watched(env, || {
            side_by_side::run(
                env,
                // The web app's unit tests run on wasm32, as the app does, in the
                // browser tests' stage: natively they would cost a build of Leptos and
                // the browser bindings that nothing else here needs.
                &[
                    "--workspace",
                    "--exclude",
                    "floatball-e2e",
                    "--exclude",
                    "floatball-web",
                ],
                // ser2net, liblo-tools and ola were installed above: their absence is
                // a failure, not a skip.
                &[
                    (tools::REQUIRE_SER2NET, "1".into()),
                    (tools::REQUIRE_LIBLO, "1".into()),
                    (tools::REQUIRE_OLA, "1".into()),
                ],
                &NATIVE,
            )
        })
    });
    // The app as operators get it (release, `wasm-opt`): the end-to-end tests run it
    // and hold its first load to the budget. Its build spends minutes on one
    // core (fat LTO, then `wasm-opt`), so it runs in the background, its output kept
    // for the end, while the wasm32 tests, the browser tests and the build of the
    // end-to-end tests take the other. The end-to-end tests run the `floatball` the
    // native tests built (`target/debug/floatball`, linked for the bridge's
    // integration tests): a `cargo build` of the bridge alone would compile its
    // dependencies again, with the features the tests do not unify in.
    stage(SIDE_BY_SIDE_STAGE, &|env| {
        let (mut ended, app_log) = std::thread::scope(|scope| {
            let app = scope.spawn(|| {
                let mut log = String::new();
                let part = part(RELEASE_APP_PART, || {
                    release_app_in_background(env, &mut log)
                });
                (part, log)
            });
            let mut ended = vec![
                part("shared tests on wasm32 (Node.js)", || {
                    let mut command = tools::cargo(env);
                    command.args([
                        "test",
                        "--package",
                        "floatball-shared",
                        "--target",
                        "wasm32-unknown-unknown",
                    ]);
                    side_by_side::run_timed(command)
                }),
                part("web tests in headless Chromium (wasm-pack)", || {
                    watched(env, || {
                        let mut command = tools::program(env, "wasm-pack");
                        command
                            .args(["test", "--headless", "--chrome", "--chromedriver"])
                            .arg(tools::CHROMEDRIVER)
                            .arg("web");
                        side_by_side::run_timed(command)
                    })
                }),
                part("build the end-to-end tests", || {
                    side_by_side::build_only(env, &END_TO_END_ARGS, &end_to_end_envs(env))
                }),
            ];
            let (app, log) = app.join().unwrap_or_else(|_| {
                (
                    Part::failed(RELEASE_APP_PART, "the thread of the app's build panicked"),
                    String::new(),
                )
            });
            ended.push(app);
            (ended, log)
        });
        println!("\nxtask: the output of `{RELEASE_APP_PART}`, which ran beside the parts above:");
        print!("{app_log}");
        ended.sort_by_key(|part| part.name != RELEASE_APP_PART);
        let failed: Vec<String> = ended
            .iter()
            .filter_map(|part| {
                part.error
                    .as_ref()
                    .map(|error| format!("{}: {error}", part.name))
            })
            .collect();
        for part in &ended {
            println!("xtask: {}", part.line());
        }
        parts
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .append(&mut ended);
        if failed.is_empty() {
            Ok(())
        } else {
            Err(failed.join("; "))
        }
    });
    stage(
        "end-to-end tests (real bridge, headless Chromium)",
        &|env| {
            watched(env, || {
                side_by_side::run(env, &END_TO_END_ARGS, &end_to_end_envs(env), &END_TO_END)
            })
        },
    );

    println!("\nxtask: summary");
    for outcome in &outcomes {
        let mark = if outcome.error.is_none() {
            "ok  "
        } else {
            "FAIL"
        };
        println!("  {mark} {:<52} {:>7.1} s", outcome.name, outcome.seconds);
        if outcome.name == SIDE_BY_SIDE_STAGE {
            for part in parts.lock().unwrap_or_else(PoisonError::into_inner).iter() {
                println!("         {}", part.line());
            }
        }
        if let Some(error) = &outcome.error {
            // The end of a log is often all that is kept of it: the reason goes here
            // too, not only under the stage's own heading.
            let shown: String = error.chars().take(ERROR_SHOWN_CHARS).collect();
            let more = if shown.len() < error.len() {
                " …"
            } else {
                ""
            };
            println!("       {shown}{more}");
        }
    }
    println!("xtask: disk: {}", tools::free_space(&env.target_dir));
    let failed = outcomes.iter().filter(|o| o.error.is_some()).count();
    let passed = outcomes.len() - failed;
    println!("{passed} passed, {failed} failed");
    if failed == 0 {
        Ok(())
    } else {
        Err(format!("{failed} stage(s) failed"))
    }
}

/// Runs a stage's `body`; then fails the stage if a process it started still runs
/// (naming and killing it: see [`leftovers`]), as well as when `body` failed.
fn watched(env: &Env, body: impl FnOnce() -> Result<(), String>) -> Result<(), String> {
    let watch = leftovers::Watch::start(env);
    let outcome = body();
    match (outcome, watch.finish()) {
        (Ok(()), left) => left,
        (Err(failed), Ok(())) => Err(failed),
        (Err(failed), Err(left)) => Err(format!("{failed}; {left}")),
    }
}

fn install_tools(env: &Env) -> Result<(), String> {
    tools::ensure_wasm_target(env)?;
    tools::ensure_wasm_bindgen_cli(env)?;
    tools::ensure_wasm_pack(env)?;
    tools::ensure_chromium(env)?;
    tools::ensure_ser2net(env)?;
    tools::ensure_liblo_tools(env)?;
    tools::ensure_ola(env)
}
