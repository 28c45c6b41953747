//! Test binaries run side by side: `cargo test --no-run` builds them, then they run
//! as many at a time as the machine has cores (at least two), longest first, each
//! one's output printed whole when it ends; the doc tests run after them with
//! `cargo test --doc`.
//!
//! Most of the project's test binaries spend their time waiting — on a bridge's
//! start-up, a simulated 9600-baud line, a browser — so two of them share two cores
//! well and the stage takes about half as long. The few whose figures or deadlines
//! depend on having the machine to themselves (the e-stop races, the short versions
//! of the benchmarks) are named in [`Plan::solo`]: they run afterwards, one at a time,
//! with nothing else running.
//!
//! Every binary runs as `cargo test` runs it: from its package's directory, with
//! `CARGO_MANIFEST_DIR` and `CARGO_PKG_NAME` set, and the arguments given after `--`.
//!
//! A stage ends with its ten slowest test binaries by wall time (libtest gives no
//! per-test times on stable Rust). [`run_timed`] does the same for a test command
//! that runs its binaries itself (`wasm-pack test`), timing each from cargo's
//! `Running` line to the next.

use std::collections::VecDeque;
use std::ffi::OsString;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

use crate::tools;

/// How to run one stage's test binaries.
pub struct Plan<'a> {
    /// Binaries that run alone, after the others: an integration test by its file
    /// name without `.rs` (`tests/<name>.rs`), a crate's unit tests by the crate's
    /// name (`floatball_bridge`).
    pub solo: &'a [&'a str],
    /// About how long each binary took in CI, s (the same names): the longest start
    /// first, so the last to end is a short one. Unlisted ones count as a few seconds.
    pub seconds: &'a [(&'a str, u32)],
    /// Run the doc tests too (`cargo test --doc` with the same arguments).
    pub doc_tests: bool,
    /// Integration test binaries made of a module per subject (`tests/main.rs` with
    /// `mod playback; …`), by target name: each module runs as if it were a binary
    /// of its own — in a process of its own, named by the module in `solo` and
    /// `seconds`, labelled `tests/<module>.rs`.
    pub by_module: &'a [&'a str],
}

/// A test binary as `cargo test --no-run` built it.
#[derive(Debug, Clone)]
struct Binary {
    /// What the summary calls it: `floatball-bridge tests/playback.rs`.
    label: String,
    /// The target's name (`playback`; the crate's name for unit tests).
    name: String,
    /// Whether it is an integration test (`tests/*.rs`) rather than unit tests.
    integration: bool,
    package: String,
    package_dir: PathBuf,
    executable: PathBuf,
    /// The arguments it runs with: for one module of a binary of modules, `--exact`
    /// and the module's tests.
    args: Vec<String>,
}

/// One binary's end.
struct Ended {
    label: String,
    seconds: f64,
    passed: bool,
    /// What failed inside it, said in one line (see [`failure_summary`]).
    why: String,
}

/// Builds the test binaries of `cargo test <args>`, then runs them side by side (see
/// the module doc). `envs` are set for the build and for every binary.
///
/// # Errors
/// The build failed, or which binaries failed.
pub fn run(
    env: &tools::Env,
    args: &[&str],
    envs: &[(&str, OsString)],
    plan: &Plan,
) -> Result<(), String> {
    let mut binaries = Vec::new();
    for binary in build(env, args, envs)? {
        if binary.integration && plan.by_module.contains(&binary.name.as_str()) {
            binaries.extend(modules_of(&binary, envs)?);
        } else {
            binaries.push(binary);
        }
    }
    let mut pooled: Vec<Binary> = Vec::new();
    let mut solo: Vec<Binary> = Vec::new();
    for binary in binaries {
        if plan.solo.contains(&binary.name.as_str()) {
            solo.push(binary);
        } else {
            pooled.push(binary);
        }
    }
    let expected = |binary: &Binary| {
        plan.seconds
            .iter()
            .find(|(name, _)| binary.integration && *name == binary.name)
            .map_or(3, |(_, seconds)| *seconds)
    };
    pooled.sort_by_key(|binary| std::cmp::Reverse(expected(binary)));
    let jobs = std::thread::available_parallelism()
        .map(std::num::NonZero::get)
        .unwrap_or(2)
        .max(2);
    println!(
        "xtask: {} test binaries, {jobs} at a time; then {} alone: {}",
        pooled.len(),
        solo.len(),
        solo.iter()
            .map(|binary| binary.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let started = Instant::now();
    let mut ended = run_pool(pooled, jobs, envs);
    println!(
        "xtask: side by side: {:.1} s",
        started.elapsed().as_secs_f64()
    );
    let started = Instant::now();
    ended.extend(run_pool(solo, 1, envs));
    println!("xtask: alone: {:.1} s", started.elapsed().as_secs_f64());

    let mut failures: Vec<String> = ended
        .iter()
        .filter(|end| !end.passed)
        .map(|end| format!("{} ({})", end.label, end.why))
        .collect();
    print_slowest(
        &ended
            .iter()
            .map(|end| (end.label.clone(), end.seconds))
            .collect::<Vec<_>>(),
    );
    if plan.doc_tests {
        let mut command = tools::cargo(env);
        command.args(["test", "--doc"]).args(args);
        for (key, value) in envs {
            command.env(key, value);
        }
        if let Err(why) = tools::run_command(&mut command) {
            failures.push(why);
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(format!("failed: {}", failures.join(", ")))
    }
}

/// How many of the slowest test binaries a stage names at its end.
const SLOWEST_SHOWN: usize = 10;

/// Prints the [`SLOWEST_SHOWN`] slowest of `times` (a test binary's label, its wall
/// time in s), slowest first. Per test, libtest gives no times on stable Rust
/// (`--report-time` is a nightly option): a binary's wall time is what there is.
fn print_slowest(times: &[(String, f64)]) {
    let mut times = times.to_vec();
    times.sort_by(|a, b| b.1.total_cmp(&a.1));
    println!("xtask: the slowest test binaries (wall time):");
    for (label, seconds) in times.iter().take(SLOWEST_SHOWN) {
        println!("  {seconds:>6.1} s  {label}");
    }
}

/// Runs `command` (a `cargo test` or `wasm-pack test` whose runner prints each
/// binary's results after cargo's `Running <target> (<path>)` line), its output and
/// errors passed through line by line as they come; then prints the slowest test
/// binaries, each timed from its `Running` line to the next one (or the end).
///
/// # Errors
/// The command could not start, or failed.
pub fn run_timed(command: Command) -> Result<(), String> {
    let (result, times) = run_and_time(command);
    if !times.is_empty() {
        print_slowest(&times);
    }
    result
}

/// [`run_timed`] but the printing of the slowest: how it ended, and each binary's
/// label with its wall time in s, in the order they ran.
fn run_and_time(mut command: Command) -> (Result<(), String>, Vec<(String, f64)>) {
    let described = tools::describe(&command);
    println!("xtask: $ {described}");
    let mut times: Vec<(String, f64)> = Vec::new();
    let pipe = std::io::pipe().and_then(|(reader, writer)| {
        let errors = writer.try_clone()?;
        Ok((reader, writer, errors))
    });
    let (reader, writer, errors) = match pipe {
        Ok(ends) => ends,
        Err(err) => return (Err(format!("cannot make a pipe: {err}")), times),
    };
    command.stdout(writer).stderr(errors);
    let mut child = match command.spawn() {
        Ok(child) => child,
        Err(err) => return (Err(format!("cannot start `{described}`: {err}")), times),
    };
    // The pipe's writing ends live on in the child only: the reading ends with it.
    drop(command);
    let mut current: Option<(String, Instant)> = None;
    for line in BufReader::new(reader).split(b'\n') {
        let Ok(line) = line else { break };
        let line = String::from_utf8_lossy(&line);
        println!("{line}");
        if let Some(label) = running_label(&line) {
            if let Some((label, started)) = current.take() {
                times.push((label, started.elapsed().as_secs_f64()));
            }
            current = Some((label, Instant::now()));
        }
    }
    let status = child.wait();
    if let Some((label, started)) = current.take() {
        times.push((label, started.elapsed().as_secs_f64()));
    }
    let result = match status {
        Ok(status) if status.success() => Ok(()),
        Ok(status) => Err(format!("`{described}` failed ({status})")),
        Err(err) => Err(format!("waiting for `{described}`: {err}")),
    };
    (result, times)
}

/// The test binary cargo says it starts on `line`
/// (`     Running tests/web.rs (target/…/web-1a2b.wasm)`): `tests/web.rs`.
fn running_label(line: &str) -> Option<String> {
    let rest = line.strip_prefix("     Running ")?;
    let (label, path) = rest.split_once(" (")?;
    path.ends_with(')').then(|| label.trim().to_owned())
}

/// The modules of a test binary made of modules ([`Plan::by_module`]), each as a
/// binary that runs that module's tests alone (`--exact <module>::<test> …`).
///
/// # Errors
/// The binary could not list its tests, or it has a test outside any module.
fn modules_of(binary: &Binary, envs: &[(&str, OsString)]) -> Result<Vec<Binary>, String> {
    let mut command = Command::new(&binary.executable);
    command
        .args(["--list", "--format", "terse"])
        .current_dir(&binary.package_dir);
    for (key, value) in envs {
        command.env(key, value);
    }
    let output = command
        .output()
        .map_err(|err| format!("cannot list the tests of {}: {err}", binary.label))?;
    if !output.status.success() {
        return Err(format!(
            "{} could not list its tests ({})",
            binary.label, output.status
        ));
    }
    let listed = String::from_utf8_lossy(&output.stdout);
    let mut modules: Vec<(String, Vec<String>)> = Vec::new();
    for test in tests_listed(&listed) {
        let Some((module, _)) = test.split_once("::") else {
            return Err(format!(
                "{}: test `{test}` is outside any module; its tests run module by module",
                binary.label
            ));
        };
        match modules.iter_mut().find(|(name, _)| name == module) {
            Some((_, tests)) => tests.push(test.to_owned()),
            None => modules.push((module.to_owned(), vec![test.to_owned()])),
        }
    }
    Ok(modules
        .into_iter()
        .map(|(module, tests)| Binary {
            label: format!("{} tests/{module}.rs", binary.package),
            name: module,
            args: std::iter::once("--exact".to_owned()).chain(tests).collect(),
            ..binary.clone()
        })
        .collect())
}

/// The tests `--list --format terse` lists (`name: test` lines; benchmarks left out).
fn tests_listed(listed: &str) -> impl Iterator<Item = &str> {
    listed
        .lines()
        .filter_map(|line| line.strip_suffix(": test"))
}

/// Builds the test binaries of `cargo test <args>` (with `envs` set) and runs none:
/// a later [`run`] with the same arguments finds them built.
///
/// # Errors
/// The build failed.
pub fn build_only(
    env: &tools::Env,
    args: &[&str],
    envs: &[(&str, OsString)],
) -> Result<(), String> {
    build(env, args, envs).map(|_| ())
}

/// `cargo test <args> --no-run`: the test binaries it built.
fn build(
    env: &tools::Env,
    args: &[&str],
    envs: &[(&str, OsString)],
) -> Result<Vec<Binary>, String> {
    let mut command = tools::cargo(env);
    command
        .args([
            "test",
            "--no-run",
            "--message-format=json-render-diagnostics",
        ])
        .args(args)
        .stdout(Stdio::piped());
    for (key, value) in envs {
        command.env(key, value);
    }
    println!("xtask: $ {}", tools::describe(&command));
    let mut child = command
        .spawn()
        .map_err(|err| format!("cannot start cargo: {err}"))?;
    let stdout = child.stdout.take().ok_or("cargo's output was not piped")?;
    let mut binaries = Vec::new();
    for line in BufReader::new(stdout).lines() {
        let line = line.map_err(|err| format!("reading cargo's output: {err}"))?;
        let Ok(message) = serde_json::from_str::<serde_json::Value>(&line) else {
            println!("{line}");
            continue;
        };
        if let Some(binary) = binary_of(&message) {
            binaries.push(binary);
        }
    }
    let status = child
        .wait()
        .map_err(|err| format!("waiting for cargo: {err}"))?;
    if !status.success() {
        return Err(format!("building the tests failed ({status})"));
    }
    Ok(binaries)
}

/// The test binary a `compiler-artifact` message of cargo's describes, if it is one.
fn binary_of(message: &serde_json::Value) -> Option<Binary> {
    if message["reason"] != "compiler-artifact" || message["profile"]["test"] != true {
        return None;
    }
    let executable = PathBuf::from(message["executable"].as_str()?);
    let target = &message["target"];
    let name = target["name"].as_str()?.to_owned();
    let kinds = target["kind"].as_array()?;
    let integration = kinds.iter().any(|kind| kind == "test");
    let package_dir = Path::new(message["manifest_path"].as_str()?)
        .parent()?
        .to_path_buf();
    // `path+file:///…/bridge#floatball-bridge@0.1.0`, or `…#0.1.0` when the package is
    // named as its folder.
    let package_id = message["package_id"].as_str().unwrap_or_default();
    let package = package_id
        .rsplit_once('#')
        .map(|(path, rest)| match rest.split_once('@') {
            Some((package, _)) => package.to_owned(),
            None => path.rsplit('/').next().unwrap_or(path).to_owned(),
        })
        .unwrap_or_else(|| name.clone());
    let label = if integration {
        format!("{package} tests/{name}.rs")
    } else {
        format!("{package} unit tests ({})", kinds_label(kinds))
    };
    Some(Binary {
        label,
        name,
        integration,
        package,
        package_dir,
        executable,
        args: Vec::new(),
    })
}

fn kinds_label(kinds: &[serde_json::Value]) -> String {
    kinds
        .iter()
        .filter_map(serde_json::Value::as_str)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Runs `binaries`, `jobs` at a time; prints each one's output whole as it ends.
fn run_pool(binaries: Vec<Binary>, jobs: usize, envs: &[(&str, OsString)]) -> Vec<Ended> {
    let queue = Arc::new(Mutex::new(VecDeque::from(binaries)));
    let ended = Arc::new(Mutex::new(Vec::new()));
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            let (queue, ended) = (Arc::clone(&queue), Arc::clone(&ended));
            scope.spawn(move || {
                loop {
                    let next = queue
                        .lock()
                        .unwrap_or_else(PoisonError::into_inner)
                        .pop_front();
                    let Some(binary) = next else { break };
                    let end = run_one(&binary, envs);
                    ended
                        .lock()
                        .unwrap_or_else(PoisonError::into_inner)
                        .push(end);
                }
            });
        }
    });
    Arc::try_unwrap(ended)
        .map(|ended| ended.into_inner().unwrap_or_else(PoisonError::into_inner))
        .unwrap_or_default()
}

/// Runs one binary as `cargo test` would; prints its output whole.
fn run_one(binary: &Binary, envs: &[(&str, OsString)]) -> Ended {
    let started = Instant::now();
    let mut command = Command::new(&binary.executable);
    command
        .args(&binary.args)
        .current_dir(&binary.package_dir)
        .env("CARGO_MANIFEST_DIR", &binary.package_dir)
        .env("CARGO_PKG_NAME", &binary.package);
    for (key, value) in envs {
        command.env(key, value);
    }
    let output = command.stdin(Stdio::null()).output();
    let seconds = started.elapsed().as_secs_f64();
    let (passed, text) = match output {
        Ok(output) => {
            let mut text = String::from_utf8_lossy(&output.stdout).into_owned();
            text.push_str(&String::from_utf8_lossy(&output.stderr));
            (output.status.success(), text)
        }
        Err(err) => (
            false,
            format!("cannot start {}: {err}\n", binary.executable.display()),
        ),
    };
    // One block per binary: `println!` holds stdout's lock for the whole block.
    println!(
        "\n     Running {} ({}) — {} in {seconds:.1} s\n{text}",
        binary.label,
        binary.executable.display(),
        if passed { "ok" } else { "FAILED" },
    );
    Ended {
        label: binary.label.clone(),
        seconds,
        passed,
        why: if passed {
            String::new()
        } else {
            failure_summary(&text)
        },
    }
}

/// How many characters of a panic's message [`failure_summary`] keeps.
const PANIC_SHOWN_CHARS: usize = 240;

/// One line saying what failed in a test binary's output: the failed tests libtest
/// lists at its end, and the first panic's place and message — so a stage's summary,
/// the end of a CI log, names the test and the reason and not only the binary.
fn failure_summary(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let listed = lines
        .iter()
        .rposition(|line| *line == "failures:")
        .map(|at| {
            lines[at + 1..]
                .iter()
                .take_while(|line| line.starts_with("    ") || line.is_empty())
                .map(|line| line.trim())
                .filter(|name| !name.is_empty())
                .collect::<Vec<_>>()
        })
        .unwrap_or_default();
    let panic = lines
        .iter()
        .position(|line| line.contains("panicked at "))
        .map(|at| {
            let place = lines[at]
                .split_once("panicked at ")
                .map_or("", |(_, place)| place.trim_end_matches(':'));
            let message: String = lines
                .get(at + 1)
                .unwrap_or(&"")
                .chars()
                .take(PANIC_SHOWN_CHARS)
                .collect();
            format!("{place}: {message}")
        });
    match (listed.is_empty(), panic) {
        (true, None) => "no test failed: the binary itself did".to_owned(),
        (true, Some(panic)) => panic,
        (false, None) => listed.join(", "),
        (false, Some(panic)) => format!("{}; first panic at {panic}", listed.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_test_binary_is_read_from_cargos_message() {
        let message = serde_json::json!({
            "reason": "compiler-artifact",
            "package_id": "path+file:///work/main/bridge#floatball-bridge@0.1.0",
            "manifest_path": "/work/main/bridge/Cargo.toml",
            "target": {"kind": ["test"], "name": "playback", "src_path": "/work/main/bridge/tests/playback.rs"},
            "profile": {"test": true},
            "executable": "/work/main/target/debug/deps/playback-5744b8ecdcc223db"
        });
        let binary = binary_of(&message).expect("a test binary");
        assert!(binary.integration);
        assert_eq!(binary.name, "playback");
        assert_eq!(binary.package, "floatball-bridge");
        assert_eq!(binary.label, "floatball-bridge tests/playback.rs");
        assert_eq!(binary.package_dir, Path::new("/work/main/bridge"));

        let unit = serde_json::json!({
            "reason": "compiler-artifact",
            "package_id": "path+file:///work/main/xtask#0.1.0",
            "manifest_path": "/work/main/xtask/Cargo.toml",
            "target": {"kind": ["bin"], "name": "xtask"},
            "profile": {"test": true},
            "executable": "/work/main/target/debug/deps/xtask-1"
        });
        let binary = binary_of(&unit).expect("unit tests");
        assert!(!binary.integration);
        assert_eq!(binary.package, "xtask");
        assert_eq!(binary.label, "xtask unit tests (bin)");
    }

    #[test]
    fn a_terse_list_gives_the_tests() {
        let listed = "playback::a_show_plays: test\nscl::x::y: test\nbench_one: benchmark\n";
        assert_eq!(
            tests_listed(listed).collect::<Vec<_>>(),
            ["playback::a_show_plays", "scl::x::y"]
        );
    }

    #[test]
    fn a_failure_is_said_by_its_tests_and_first_panic() {
        let text = "running 2 tests\ntest a ... FAILED\ntest b ... ok\n\nfailures:\n\n\
            ---- a stdout ----\n\nthread 'a' (7) panicked at bridge/tests/live.rs:86:5:\n\
            olad is not installed\nnote: run with `RUST_BACKTRACE=1`\n\n\nfailures:\n    a\n\n\
            test result: FAILED. 1 passed; 1 failed\n";
        assert_eq!(
            failure_summary(text),
            "a; first panic at bridge/tests/live.rs:86:5: olad is not installed"
        );
        assert_eq!(
            failure_summary("Segmentation fault\n"),
            "no test failed: the binary itself did"
        );
    }

    #[test]
    fn cargos_running_line_names_the_binary() {
        assert_eq!(
            running_label(
                "     Running unittests src/lib.rs (target/wasm32-unknown-unknown/debug/deps/floatball_web-1.wasm)"
            )
            .as_deref(),
            Some("unittests src/lib.rs")
        );
        assert_eq!(
            running_label("     Running tests/web.rs (target/debug/deps/web-2)").as_deref(),
            Some("tests/web.rs")
        );
        // wasm-bindgen-test-runner's own line, and test output, are not cargo's.
        assert_eq!(
            running_label("Running headless tests in Chrome on `http://127.0.0.1:1/`"),
            None
        );
        assert_eq!(running_label("test running ... ok"), None);
    }

    #[test]
    fn run_timed_passes_the_output_through_and_times_each_binary() {
        let mut command = Command::new("sh");
        command.args([
            "-c",
            "echo '     Running tests/a.rs (a)'; sleep 0.3; \
             echo '     Running tests/b.rs (b)' >&2; echo done",
        ]);
        let (result, times) = run_and_time(command);
        assert_eq!(result, Ok(()));
        let labels: Vec<&str> = times.iter().map(|(label, _)| label.as_str()).collect();
        assert_eq!(labels, ["tests/a.rs", "tests/b.rs"]);
        assert!(times[0].1 >= 0.25 && times[1].1 < 0.25, "{times:?}");
        let mut failing = Command::new("sh");
        failing.args(["-c", "exit 3"]);
        assert!(run_timed(failing).is_err());
    }

    #[test]
    fn a_library_or_a_non_test_artifact_is_not_a_test_binary() {
        let library = serde_json::json!({
            "reason": "compiler-artifact",
            "package_id": "path+file:///work/main/shared#floatball-shared@0.1.0",
            "manifest_path": "/work/main/shared/Cargo.toml",
            "target": {"kind": ["lib"], "name": "floatball_shared"},
            "profile": {"test": false},
            "executable": null
        });
        assert!(binary_of(&library).is_none());
        let finished = serde_json::json!({"reason": "build-finished", "success": true});
        assert!(binary_of(&finished).is_none());
    }
}
