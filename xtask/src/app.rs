//! Building the web app: `floatball-web` compiled to wasm32, then `wasm-bindgen`
//! writes `static/pkg/floatball.js` and `static/pkg/floatball_bg.wasm`.

use crate::tools::{self, Env};

/// How the app is built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Build {
    /// Small and fast, as operators get it (`cargo xtask run`): the `wasm-release`
    /// profile of the workspace `Cargo.toml`.
    Release,
    /// For the end-to-end tests: the dev profile, which reuses what the browser tests
    /// already compiled instead of compiling every dependency again.
    Test,
}

impl Build {
    fn profile(self) -> &'static str {
        match self {
            Build::Release => "wasm-release",
            Build::Test => "dev",
        }
    }

    /// The directory cargo puts the profile's output in.
    fn dir(self) -> &'static str {
        match self {
            Build::Release => "wasm-release",
            Build::Test => "debug",
        }
    }
}

/// Builds the app into `static/pkg/`.
pub fn build_web(env: &Env, build: Build) -> Result<(), String> {
    println!(
        "xtask: building the web app ({} profile) into static/pkg/",
        build.profile()
    );
    tools::run_command(tools::cargo(env).args([
        "build",
        "--package",
        "floatball-web",
        "--lib",
        "--target",
        "wasm32-unknown-unknown",
        "--profile",
        build.profile(),
    ]))?;
    let wasm = env
        .target_dir
        .join("wasm32-unknown-unknown")
        .join(build.dir())
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
