//! `cargo xtask test`: every check and test, one stage at a time, with a one-line
//! summary per stage and a final `N passed, N failed` line.
//!
//! Stages keep going after a failure so one run shows everything that is wrong; the
//! command fails if any stage failed.
//!
//! The stages that start processes (the native, web and end-to-end tests) fail if
//! any they started still runs when they end, and kill it (see [`leftovers`]); the
//! test stages end with their slowest test binaries.

use std::ffi::OsString;
use std::time::Instant;

use crate::app;
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
        // Live input from olad's Art-Net and sACN (fixed ports 6454 and 5568).
        "live",
        // The bridge's unit tests: the SCL line's e-stop within 20 ms of the press.
        "floatball_bridge",
        // The storm (issue 52): floods every input of a bridge and holds a pong and
        // an answer to 2 s; beside another binary its load would slow that one's
        // deadlines, and the other's its own.
        "untrusted",
    ],
    seconds: &[
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
        ("commission", 53),
        ("create", 45),
        ("screens", 42),
        ("operator_mbox", 39),
        ("controls", 28),
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
                &["--workspace", "--exclude", "floatball-e2e"],
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
    stage("shared tests on wasm32 (Node.js)", &|env| {
        let mut command = tools::cargo(env);
        command.args([
            "test",
            "--package",
            "floatball-shared",
            "--target",
            "wasm32-unknown-unknown",
        ]);
        side_by_side::run_timed(command)
    });
    stage("web tests in headless Chromium (wasm-pack)", &|env| {
        watched(env, || {
            let mut command = tools::program(env, "wasm-pack");
            command
                .args(["test", "--headless", "--chrome", "--chromedriver"])
                .arg(tools::CHROMEDRIVER)
                .arg("web");
            side_by_side::run_timed(command)
        })
    });
    // The app as operators get it (release, `wasm-opt`): the end-to-end tests run it
    // and hold its first load to the budget (issue 35). They run the `floatball` the
    // native tests built (`target/debug/floatball`, linked for the bridge's
    // integration tests): a `cargo build` of the bridge alone would compile its
    // dependencies again, with the features the tests do not unify in.
    //
    // Once cargo has compiled the app, `wasm-opt` keeps one core busy for over a
    // minute: the end-to-end tests are compiled beside it, so that stage starts with
    // its binaries built.
    stage("build the app (release)", &|env| {
        let envs = end_to_end_envs(env);
        app::build_web_beside(
            env,
            app::Build::Release,
            Some(&|| side_by_side::build_only(env, &END_TO_END_ARGS, &envs)),
        )
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
