//! `cargo xtask create-bench`: what one change of a parameter on the Create page costs
//! in the app as it is served, with figures.
//!
//! Runs the browser benchmark `web/tests/create.rs` (the `create::` module of the
//! browser tests' binary) in headless Chromium, built with the `wasm-release` profile
//! `cargo xtask build` serves (not `wasm-pack test --release`, whose size-optimised
//! parts would differ): for a 10 × 10 and a
//! 100 × 100 matrix and a 22 s and a 60 s show, the median and largest time from the
//! change to the new picture drawn, and what generating, handing the show to the stage
//! and the limit check after the picture take. Nothing about speed is asserted.

use crate::tools::{self, Env};

/// Builds and runs the benchmark.
///
/// # Errors
/// A tool could not be installed, or the build or the run failed.
pub fn create_bench(args: &[String]) -> Result<(), String> {
    if !args.is_empty() {
        return Err(format!(
            "unknown options {args:?}\n\nusage: cargo xtask create-bench"
        ));
    }
    let root = tools::workspace_root();
    let env = Env::discover(&root)?;
    tools::ensure_wasm_target(&env)?;
    tools::ensure_wasm_bindgen_cli(&env)?;
    tools::ensure_chromium(&env)?;
    println!("xtask: the Create page's change → picture, as served (wasm-release profile)");
    tools::run_command(
        tools::cargo(&env)
            .args([
                "test",
                "--profile",
                "wasm-release",
                "--target",
                "wasm32-unknown-unknown",
                "--package",
                "floatball-web",
                "--test",
                "browser",
                "--",
                "create::",
                "--nocapture",
            ])
            // Cargo runs the test's wasm with wasm-bindgen's runner, which drives
            // Chromium through ChromeDriver with `web/webdriver.json`'s options.
            .env(
                "CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUNNER",
                "wasm-bindgen-test-runner",
            )
            .env("CHROMEDRIVER", tools::CHROMEDRIVER),
    )
}
