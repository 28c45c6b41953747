//! Building the web app: `floatball-web` compiled to wasm32, then `wasm-bindgen`
//! writes `static/pkg/floatball.js` and `static/pkg/floatball_bg.wasm`.

use crate::tools::{self, Env};

/// The cargo profile the served app is built with (see the workspace `Cargo.toml`).
const PROFILE: &str = "wasm-release";

/// Builds the app into `static/pkg/`.
pub fn build_web(env: &Env) -> Result<(), String> {
    println!("xtask: building the web app into static/pkg/");
    tools::run_command(tools::cargo(env).args([
        "build",
        "--package",
        "floatball-web",
        "--lib",
        "--target",
        "wasm32-unknown-unknown",
        "--profile",
        PROFILE,
    ]))?;
    let wasm = env
        .target_dir
        .join("wasm32-unknown-unknown")
        .join(PROFILE)
        .join("floatball_web.wasm");
    let out_dir = env.root.join("static").join("pkg");
    tools::run_command(
        tools::program(env, "wasm-bindgen")
            .arg(&wasm)
            .arg("--out-dir")
            .arg(&out_dir)
            .args([
                "--out-name",
                "floatball",
                "--target",
                "web",
                "--no-typescript",
            ]),
    )
}
