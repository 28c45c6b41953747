//! Finding and installing what the build and the tests need.
//!
//! Every install says what it installs and why before it starts. Nothing is
//! downloaded outside the package registries: Rust tools come from crates.io through
//! `cargo install`, the browser, `ser2net`, `liblo-tools` and `ola` from Debian's packages through
//! `apt-get`, `wasm-opt` from npm's `binaryen` package into the target directory.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// Where things are: the workspace, its target directory, and a `PATH` that starts
/// with the directory `cargo install` puts binaries in.
#[derive(Debug, Clone)]
pub struct Env {
    /// The workspace root (where `Cargo.lock` is).
    pub root: PathBuf,
    /// Cargo's target directory (honours `CARGO_TARGET_DIR`).
    pub target_dir: PathBuf,
    /// `PATH` with `$CARGO_HOME/bin` first, so freshly installed tools are found.
    pub path: OsString,
}

/// The workspace root: the parent of this crate's directory.
pub fn workspace_root() -> PathBuf {
    let manifest_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    manifest_dir
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or(manifest_dir)
}

impl Env {
    /// Finds the target directory and cargo's bin directory.
    pub fn discover(root: &Path) -> Result<Self, String> {
        let cargo_home = std::env::var_os("CARGO_HOME")
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").map(|home| PathBuf::from(home).join(".cargo")))
            .ok_or("neither CARGO_HOME nor HOME is set")?;
        let cargo_bin = cargo_home.join("bin");
        let mut paths = vec![cargo_bin.clone()];
        if let Some(existing) = std::env::var_os("PATH") {
            paths.extend(std::env::split_paths(&existing));
        }
        let path = std::env::join_paths(paths).map_err(|err| format!("bad PATH: {err}"))?;
        let target_dir = match std::env::var_os("CARGO_TARGET_DIR") {
            Some(dir) => {
                let dir = PathBuf::from(dir);
                if dir.is_absolute() {
                    dir
                } else {
                    root.join(dir)
                }
            }
            None => root.join("target"),
        };
        Ok(Self {
            root: root.to_path_buf(),
            target_dir,
            path,
        })
    }
}

/// A `cargo` command run from the workspace root with our `PATH`.
pub fn cargo(env: &Env) -> Command {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    command_in(env, cargo)
}

/// Any program, run from the workspace root with our `PATH`.
pub fn program(env: &Env, name: &str) -> Command {
    command_in(env, name)
}

/// `program` run from the workspace root with our `PATH`.
///
/// Builds started from here (cargo, wasm-pack) are not incremental: the xtask builds
/// each thing once, and incremental caches would take gigabytes of a CI machine's disk
/// for nothing.
fn command_in(env: &Env, program: impl AsRef<std::ffi::OsStr>) -> Command {
    let mut command = Command::new(program);
    command
        .current_dir(&env.root)
        .env("PATH", &env.path)
        .env("CARGO_INCREMENTAL", "0");
    command
}

/// Free space on the disk that holds `dir`, as `df` reports it (for the log: a full
/// disk is the commonest reason for a build to fail on a CI machine).
pub fn free_space(dir: &Path) -> String {
    let mut probe = dir;
    while !probe.exists() {
        match probe.parent() {
            Some(parent) => probe = parent,
            None => break,
        }
    }
    output_of(Command::new("df").args(["-Ph"]).arg(probe))
        .and_then(|text| {
            let fields: Vec<&str> = text.lines().nth(1)?.split_whitespace().collect();
            Some(format!(
                "{} free of {} on {}",
                fields.get(3)?,
                fields.get(1)?,
                fields.get(5)?
            ))
        })
        .unwrap_or_else(|| "unknown (df failed)".to_owned())
}

/// Prints and runs `command`, failing if it does not exit successfully.
pub fn run_command(command: &mut Command) -> Result<(), String> {
    println!("xtask: $ {}", describe(command));
    let status = command
        .status()
        .map_err(|err| format!("cannot start `{}`: {err}", describe(command)))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{}` failed ({status})", describe(command)))
    }
}

/// The stdout of `command` if it runs and succeeds.
fn output_of(command: &mut Command) -> Option<String> {
    let output = command.stderr(Stdio::null()).output().ok()?;
    output
        .status
        .success()
        .then(|| String::from_utf8_lossy(&output.stdout).into_owned())
}

pub fn describe(command: &Command) -> String {
    let mut text = command.get_program().to_string_lossy().into_owned();
    for arg in command.get_args() {
        text.push(' ');
        text.push_str(&arg.to_string_lossy());
    }
    text
}

/// Adds the `wasm32-unknown-unknown` target if rustup does not have it.
pub fn ensure_wasm_target(env: &Env) -> Result<(), String> {
    let installed = output_of(program(env, "rustup").args(["target", "list", "--installed"]))
        .ok_or("cannot ask rustup for the installed targets; is rustup installed?")?;
    if installed
        .lines()
        .any(|line| line.trim() == "wasm32-unknown-unknown")
    {
        return Ok(());
    }
    println!(
        "xtask: installing the wasm32-unknown-unknown target (the web app is compiled to WebAssembly)"
    );
    run_command(program(env, "rustup").args(["target", "add", "wasm32-unknown-unknown"]))
}

/// The `wasm-bindgen` version recorded in `Cargo.lock`.
pub fn locked_wasm_bindgen_version(root: &Path) -> Result<String, String> {
    let lock = std::fs::read_to_string(root.join("Cargo.lock"))
        .map_err(|err| format!("cannot read Cargo.lock: {err}"))?;
    locked_version(&lock, "wasm-bindgen")
        .ok_or_else(|| "Cargo.lock has no wasm-bindgen package".to_owned())
}

/// The version of package `name` in the text of a `Cargo.lock`.
pub fn locked_version(lock: &str, name: &str) -> Option<String> {
    let wanted = format!("name = \"{name}\"");
    let mut lines = lock.lines();
    while let Some(line) = lines.next() {
        if line.trim() == wanted {
            let version = lines.next()?.trim();
            return version
                .strip_prefix("version = \"")
                .and_then(|rest| rest.strip_suffix('"'))
                .map(str::to_owned);
        }
    }
    None
}

/// Installs `wasm-bindgen-cli` at exactly the `wasm-bindgen` version in `Cargo.lock`
/// (the generated glue and the library must match to the patch version).
pub fn ensure_wasm_bindgen_cli(env: &Env) -> Result<(), String> {
    let wanted = locked_wasm_bindgen_version(&env.root)?;
    let have = output_of(program(env, "wasm-bindgen").arg("--version"));
    let runner = output_of(program(env, "wasm-bindgen-test-runner").arg("--version"));
    let matches = |out: &Option<String>| {
        out.as_deref()
            .and_then(|text| text.split_whitespace().nth(1))
            .is_some_and(|version| version == wanted)
    };
    if matches(&have) && matches(&runner) {
        return Ok(());
    }
    println!(
        "xtask: installing wasm-bindgen-cli {wanted} (it must match the wasm-bindgen version in Cargo.lock; {})",
        match have {
            Some(text) => format!("found {}", text.trim()),
            None => "none found".to_owned(),
        }
    );
    cargo_install(env, "wasm-bindgen-cli", Some(&wanted))
}

/// `cargo install` of `krate` (at `version` if given), with `--locked` first.
fn cargo_install(env: &Env, krate: &str, version: Option<&str>) -> Result<(), String> {
    let install = |locked: bool| {
        let mut command = cargo(env);
        command.args(["install", krate, "--force"]);
        if let Some(version) = version {
            command.args(["--version", version]);
        }
        if locked {
            command.arg("--locked");
        }
        run_command(&mut command)
    };
    install(true).or_else(|err| {
        // A release's own lock file can pin a dependency version the registry has
        // since withdrawn; the same release then still builds with fresh resolution.
        println!("xtask: {err}; retrying without --locked");
        install(false)
    })
}

/// Installs `wasm-pack` (it runs the web app's tests in Chromium) if it is missing.
pub fn ensure_wasm_pack(env: &Env) -> Result<(), String> {
    if output_of(program(env, "wasm-pack").arg("--version")).is_some() {
        return Ok(());
    }
    println!("xtask: installing wasm-pack (it runs the web app's tests in headless Chromium)");
    cargo_install(env, "wasm-pack", None)
}

/// The version of npm's `binaryen` package whose `wasm-opt` shrinks the release app.
pub const BINARYEN_VERSION: &str = "132.0.0";

/// The WebAssembly features rustc enables for `wasm32-unknown-unknown` (and every
/// browser the app supports has), which `wasm-opt` must be told to accept.
pub const WASM_FEATURES: [&str; 6] = [
    "--enable-bulk-memory",
    "--enable-mutable-globals",
    "--enable-nontrapping-float-to-int",
    "--enable-sign-ext",
    "--enable-reference-types",
    "--enable-multivalue",
];

/// The path of `wasm-opt`, installing npm's `binaryen` package at
/// [`BINARYEN_VERSION`] under `<target>/xtask-tools/binaryen` if it is not there.
pub fn ensure_wasm_opt(env: &Env) -> Result<PathBuf, String> {
    let major = BINARYEN_VERSION
        .split('.')
        .next()
        .unwrap_or(BINARYEN_VERSION);
    npm_tool(
        env,
        NpmTool {
            package: "binaryen",
            version: BINARYEN_VERSION,
            bin: "wasm-opt",
            version_says: &format!("version {major} "),
            purpose: "it shrinks the release app",
        },
    )
}

/// The version of npm's `terser` whose minifier shrinks the release app's js.
pub const TERSER_VERSION: &str = "5.51.4";

/// The path of `terser`, installing npm's `terser` package at [`TERSER_VERSION`]
/// under `<target>/xtask-tools/terser` if it is not there.
pub fn ensure_terser(env: &Env) -> Result<PathBuf, String> {
    npm_tool(
        env,
        NpmTool {
            package: "terser",
            version: TERSER_VERSION,
            bin: "terser",
            version_says: TERSER_VERSION,
            purpose: "it shrinks the release app's js",
        },
    )
}

/// A tool that comes from an npm package.
struct NpmTool<'a> {
    /// The npm package.
    package: &'a str,
    /// Its version.
    version: &'a str,
    /// The program under `node_modules/.bin`.
    bin: &'a str,
    /// What the program's `--version` says when it is the right one.
    version_says: &'a str,
    /// What it is for, for the message that installs it.
    purpose: &'a str,
}

/// The path of an npm package's program, installing the package (and Node.js and npm
/// when they are missing) under `<target>/xtask-tools/<package>` if the right version
/// is not there.
fn npm_tool(env: &Env, tool: NpmTool<'_>) -> Result<PathBuf, String> {
    let NpmTool {
        package,
        version,
        bin,
        version_says,
        purpose,
    } = tool;
    let prefix = env.target_dir.join("xtask-tools").join(package);
    let path = prefix.join("node_modules").join(".bin").join(bin);
    let have = output_of(program(env, &path.to_string_lossy()).arg("--version"));
    if have.is_some_and(|text| text.contains(version_says)) {
        return Ok(path);
    }
    if output_of(program(env, "npm").arg("--version")).is_none() {
        apt_install(
            env,
            &["nodejs", "npm"],
            &format!("Node.js and npm ({bin}, which shrinks the release app, comes from npm)"),
        )?;
    }
    println!(
        "xtask: installing {bin} (npm package {package} {version}) into {}; {purpose}",
        prefix.display()
    );
    std::fs::create_dir_all(&prefix)
        .map_err(|err| format!("cannot create {}: {err}", prefix.display()))?;
    run_command(
        program(env, "npm")
            .arg("install")
            .arg("--prefix")
            .arg(&prefix)
            .args(["--no-audit", "--no-fund"])
            .arg(format!("{package}@{version}")),
    )?;
    Ok(path)
}

/// The path of ChromeDriver.
pub const CHROMEDRIVER: &str = "/usr/bin/chromedriver";
/// The path of Chromium.
pub const CHROMIUM: &str = "/usr/bin/chromium";

/// The Debian package with Chinese glyphs for the browser tests' screenshots
/// (`tests/tests/screens.rs` shows every page in 中文), installed only when no font
/// for Chinese is there.
pub const CJK_FONT_PACKAGE: &str = "fonts-wqy-microhei";

/// Installs Debian's Chromium and ChromeDriver, and a font with Chinese glyphs, when
/// running as root; otherwise stops with the command to run.
pub fn ensure_chromium(env: &Env) -> Result<(), String> {
    let mut missing = Vec::new();
    if !(Path::new(CHROMIUM).is_file() && Path::new(CHROMEDRIVER).is_file()) {
        missing.extend(["chromium", "chromium-driver"]);
    }
    // `fc-list :lang=zh` lists the fonts that cover Chinese (none: empty).
    let cjk_font = output_of(program(env, "fc-list").arg(":lang=zh"))
        .is_some_and(|fonts| !fonts.trim().is_empty());
    if !cjk_font {
        missing.push(CJK_FONT_PACKAGE);
    }
    if missing.is_empty() {
        return Ok(());
    }
    apt_install(
        env,
        &missing,
        "Chromium, ChromeDriver and a font for Chinese (the browser tests run in headless Chromium and take screenshots in 中文 and English)",
    )
}

/// The path of Debian's `ser2net` (a serial device server the bridge's network links
/// are tested against, `bridge/tests/ser2net.rs`).
pub const SER2NET: &str = "/usr/sbin/ser2net";

/// The variable that makes a missing `ser2net` fail `bridge/tests/ser2net.rs` instead
/// of skipping it (`cargo xtask test` sets it, having installed `ser2net`).
pub const REQUIRE_SER2NET: &str = "FLOATBALL_REQUIRE_SER2NET";

/// Installs Debian's `ser2net` when it is missing (as root; otherwise stops with the
/// command to run).
pub fn ensure_ser2net(env: &Env) -> Result<(), String> {
    if Path::new(SER2NET).is_file() {
        return Ok(());
    }
    apt_install(
        env,
        &["ser2net"],
        "ser2net (the bridge's tcp:// and rfc2217:// gateways are tested through a real serial device server)",
    )
}

/// The programs of Debian's `liblo-tools` (a real OSC client: `oscsend` sends,
/// `oscdump` receives) that `bridge/tests/osc.rs` drives the bridge's OSC control with.
pub const LIBLO_TOOLS: [&str; 2] = ["/usr/bin/oscsend", "/usr/bin/oscdump"];

/// The variable that makes missing `liblo-tools` fail `bridge/tests/osc.rs` instead of
/// skipping it (`cargo xtask test` sets it, having installed them).
pub const REQUIRE_LIBLO: &str = "FLOATBALL_REQUIRE_LIBLO";

/// Installs Debian's `liblo-tools` when `oscsend` or `oscdump` is missing (as root;
/// otherwise stops with the command to run).
pub fn ensure_liblo_tools(env: &Env) -> Result<(), String> {
    if LIBLO_TOOLS.iter().all(|tool| Path::new(tool).is_file()) {
        return Ok(());
    }
    apt_install(
        env,
        &["liblo-tools"],
        "liblo-tools (the bridge's OSC control is tested with a real OSC client, oscsend and oscdump)",
    )
}

/// The programs of Debian's `ola` (the Open Lighting Architecture: `olad` with its
/// Art-Net and E1.31 plugins, `ola_timecode`, `ola_set_dmx`, `ola_streaming_client`,
/// `ola_patch`) that `bridge/tests/timecode.rs` sends Art-Net timecode to the bridge
/// with, and `bridge/tests/live.rs` Art-Net and sACN.
pub const OLA_TOOLS: [&str; 5] = [
    "/usr/bin/olad",
    "/usr/bin/ola_timecode",
    "/usr/bin/ola_set_dmx",
    "/usr/bin/ola_streaming_client",
    "/usr/bin/ola_patch",
];

/// The variable that makes a missing `ola` fail `bridge/tests/timecode.rs` and
/// `bridge/tests/live.rs` instead of skipping their real senders (`cargo xtask test`
/// sets it, having installed it).
pub const REQUIRE_OLA: &str = "FLOATBALL_REQUIRE_OLA";

/// Installs Debian's `ola` when `olad` or `ola_timecode` is missing (as root;
/// otherwise stops with the command to run).
pub fn ensure_ola(env: &Env) -> Result<(), String> {
    if OLA_TOOLS.iter().all(|tool| Path::new(tool).is_file()) {
        return Ok(());
    }
    apt_install(
        env,
        &["ola"],
        "ola (the bridge's timecode chase and live input are tested with real Art-Net and sACN senders: olad and its clients)",
    )
}

/// Installs Debian `packages` (`why` says what they are for) when running as root;
/// otherwise stops with the command to run.
fn apt_install(env: &Env, packages: &[&str], why: &str) -> Result<(), String> {
    let install = format!("apt-get install -y {}", packages.join(" "));
    let uid = output_of(program(env, "id").arg("-u")).unwrap_or_default();
    if uid.trim() != "0" {
        return Err(format!(
            "{why} are needed; install them with:\n\n    sudo apt-get update && sudo {install}\n"
        ));
    }
    println!("xtask: installing Debian's {}: {why}", packages.join(", "));
    run_command(
        program(env, "apt-get")
            .arg("update")
            .env("DEBIAN_FRONTEND", "noninteractive"),
    )?;
    run_command(
        program(env, "apt-get")
            .args(["install", "-y", "--no-install-recommends"])
            .args(packages)
            .env("DEBIAN_FRONTEND", "noninteractive"),
    )
}

/// Reads `--flag N` pairs of positive numbers: `flags` names each flag and its default;
/// the values come back in the same order.
///
/// # Errors
/// A flag not in `flags` (then `usage`), or one without a positive number.
pub fn parse_counts<const N: usize>(
    args: &[String],
    flags: [(&str, u32); N],
    usage: &str,
) -> Result<[u32; N], String> {
    let mut values = flags.map(|(_, default)| default);
    let mut iter = args.iter();
    while let Some(flag) = iter.next() {
        let index = flags
            .iter()
            .position(|(name, _)| name == flag)
            .ok_or_else(|| usage.to_owned())?;
        values[index] = iter
            .next()
            .and_then(|value| value.parse().ok())
            .filter(|value| *value > 0)
            .ok_or_else(|| format!("{flag} needs a positive number"))?;
    }
    Ok(values)
}

/// The bridge's integration tests: one binary of a module per subject, whose tests
/// are `<module>::…` (`bridge/tests/main.rs`).
pub const BRIDGE_TESTS: &str = "integration";

/// The libtest filter that picks the bridge's test module `module` alone: its tests'
/// names start with `<module>::`, and no other module's name ends with `module`.
pub fn bridge_module(module: &str) -> String {
    format!("{module}::")
}

/// Builds the bridge's integration tests in release, then runs module `test` with `vars`
/// set and its output shown, after raising the open-file limit to the hard one (the
/// benches open a socket or two per simulated gateway).
///
/// # Errors
/// The build or the run failed.
pub fn run_release_bench(test: &str, vars: &[(&str, String)], banner: &str) -> Result<(), String> {
    let root = workspace_root();
    let env = Env::discover(&root)?;
    let args = [
        "test",
        "--release",
        "--package",
        "floatball-bridge",
        "--test",
        BRIDGE_TESTS,
    ];
    run_command(cargo(&env).args(args).arg("--no-run"))?;
    println!("xtask: {banner}");
    let mut command = Command::new("sh");
    command
        .current_dir(&env.root)
        .arg("-c")
        .arg("ulimit -n \"$(ulimit -Hn)\" 2>/dev/null; exec \"$@\"")
        .arg("sh")
        .arg(cargo(&env).get_program())
        .args(args)
        .arg("--")
        .arg(bridge_module(test))
        .arg("--nocapture");
    for (key, value) in vars {
        command.env(key, value);
    }
    for (key, value) in cargo(&env).get_envs() {
        match value {
            Some(value) => command.env(key, value),
            None => command.env_remove(key),
        };
    }
    run_command(&mut command)
}

#[cfg(test)]
mod tests {
    use super::*;

    const LOCK: &str = r#"
[[package]]
name = "wasm-bindgen"
version = "0.2.105"
source = "registry+https://github.com/rust-lang/crates.io-index"

[[package]]
name = "wasm-bindgen-backend"
version = "0.2.105"
"#;

    #[test]
    fn finds_the_locked_version_of_exactly_that_package() {
        assert_eq!(
            locked_version(LOCK, "wasm-bindgen").as_deref(),
            Some("0.2.105")
        );
        assert_eq!(locked_version(LOCK, "wasm-bindgen-macro"), None);
    }

    #[test]
    fn the_real_lock_file_names_wasm_bindgen() {
        let version = locked_wasm_bindgen_version(&workspace_root()).unwrap();
        assert!(version.starts_with("0.2."), "{version}");
    }
}
