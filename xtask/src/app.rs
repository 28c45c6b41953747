//! Building the web app into `static/pkg/`, as the bridge serves it.
//!
//! `floatball-web` is compiled to wasm32 and `wasm-bindgen` writes its js glue into a
//! staging directory under the target directory; a release build then goes through
//! `wasm-opt -Oz --converge --zero-filled-memory` ([`build_web`] says why).
//! [`package`] gives the wasm, the js and `static/style.css` content-hashed names
//! (`floatball_bg-<16 hex>.wasm`, `floatball-<16 hex>.js`, `style-<16 hex>.css`; the js
//! is rewritten to load the hashed wasm) and renders the page `pkg/index.html` from the
//! template `static/index.html`: its stylesheet link names the hashed css, and a
//! `modulepreload` of the js (which `static/boot.js` imports) and a `preload` of the
//! wasm start both downloads while the page is still parsed. [`write_pkg`] replaces
//! `static/pkg/` with these files and a brotli (`.br`) and gzip (`.gz`) copy of each,
//! which the bridge serves by `Accept-Encoding` (see `bridge/src/server.rs` for the
//! caching headers).

use std::io::Write as _;
use std::path::Path;

use sha2::{Digest as _, Sha256};

use crate::tools::{self, Env};

/// How the app is built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Build {
    /// Small and fast, as operators get it (`cargo xtask run`): the `wasm-release`
    /// profile of the workspace `Cargo.toml`, `wasm-opt -Oz --converge`, brotli at its best.
    Release,
    /// For the end-to-end tests: the dev profile, which reuses what the browser tests
    /// already compiled instead of compiling every dependency again; no `wasm-opt`
    /// and a quick brotli level (the tests check the headers, not the size).
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

    /// How hard the `.br` and `.gz` copies are compressed.
    fn levels(self) -> Levels {
        match self {
            Build::Release => Levels {
                brotli_quality: 11,
                gzip_level: 9,
            },
            Build::Test => Levels {
                brotli_quality: 4,
                gzip_level: 6,
            },
        }
    }
}

/// Compression levels of the copies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Levels {
    /// Brotli quality, 0–11.
    pub brotli_quality: u32,
    /// Gzip level, 0–9.
    pub gzip_level: u32,
}

/// The hashed names and contents of one build, before compression.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Packaged {
    /// The wasm's file name in `pkg/`.
    pub wasm_name: String,
    /// The js glue's file name in `pkg/`.
    pub js_name: String,
    /// The stylesheet's file name in `pkg/`.
    pub css_name: String,
    /// Every file of `pkg/` (name, content): the three above and `index.html`.
    pub files: Vec<(String, Vec<u8>)>,
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
    let staging = env.target_dir.join("web-bindgen").join(build.dir());
    if staging.exists() {
        std::fs::remove_dir_all(&staging)
            .map_err(|err| format!("cannot clear {}: {err}", staging.display()))?;
    }
    tools::run_command(
        tools::program(env, "wasm-bindgen")
            .arg(&wasm)
            .arg("--out-dir")
            .arg(&staging)
            .args([
                "--out-name",
                "floatball",
                "--target",
                "web",
                "--no-typescript",
            ]),
    )?;
    // Only the js and the wasm are packaged: glue with JS snippets (`inline_js`,
    // `module = …`) would import files that never reach static/pkg/.
    let entries = std::fs::read_dir(&staging)
        .map_err(|err| format!("cannot list {}: {err}", staging.display()))?;
    for entry in entries {
        let name = entry
            .map_err(|err| format!("cannot list {}: {err}", staging.display()))?
            .file_name();
        if name != "floatball.js" && name != "floatball_bg.wasm" {
            return Err(format!(
                "wasm-bindgen wrote {} besides the js and the wasm; xtask/src/app.rs does not package it yet",
                name.to_string_lossy()
            ));
        }
    }
    let bindgen_wasm = staging.join("floatball_bg.wasm");
    if build == Build::Release {
        let wasm_opt = tools::ensure_wasm_opt(env)?;
        tools::run_command(
            tools::program(env, &wasm_opt.to_string_lossy())
                // `--converge` repeats the passes while the module still shrinks
                // (about 2 KB of brotli). The memory a wasm module defines starts
                // zeroed (`--zero-filled-memory`). Not `--low-memory-unused`
                // (another 2 KB): the stack sits at the bottom of memory, and a
                // stack about to overflow must trap, not be optimised around.
                .args(["-Oz", "--converge", "--zero-filled-memory"])
                .args(tools::WASM_FEATURES)
                .arg(&bindgen_wasm)
                .arg("-o")
                .arg(&bindgen_wasm),
        )?;
    }
    let static_dir = env.root.join("static");
    let packaged = package(
        read(&bindgen_wasm)?,
        &read_text(&staging.join("floatball.js"))?,
        read(&static_dir.join("style.css"))?,
        &read_text(&static_dir.join("index.html"))?,
    )?;
    let pkg = static_dir.join("pkg");
    write_pkg(&pkg, &packaged, build.levels())?;
    println!(
        "xtask: wrote {} with {}, {} and {} (and .br/.gz copies)",
        pkg.join("index.html").display(),
        packaged.js_name,
        packaged.wasm_name,
        packaged.css_name
    );
    Ok(())
}

fn read(path: &Path) -> Result<Vec<u8>, String> {
    std::fs::read(path).map_err(|err| format!("cannot read {}: {err}", path.display()))
}

fn read_text(path: &Path) -> Result<String, String> {
    std::fs::read_to_string(path).map_err(|err| format!("cannot read {}: {err}", path.display()))
}

/// `<stem>-<first 16 hex digits of the SHA-256 of content>.<extension>`.
pub fn hashed_name(stem: &str, extension: &str, content: &[u8]) -> String {
    let digest = Sha256::digest(content);
    let hex: String = digest
        .iter()
        .take(8)
        .map(|byte| format!("{byte:02x}"))
        .collect();
    format!("{stem}-{hex}.{extension}")
}

/// The name wasm-bindgen's glue loads the wasm by.
const BINDGEN_WASM_NAME: &str = "floatball_bg.wasm";

/// Names the wasm and js by their content, points the js at the hashed wasm and
/// renders the page from `template` (see the module doc).
pub fn package(wasm: Vec<u8>, js: &str, css: Vec<u8>, template: &str) -> Result<Packaged, String> {
    let wasm_name = hashed_name("floatball_bg", "wasm", &wasm);
    let quoted = format!("'{BINDGEN_WASM_NAME}'");
    let references = js.matches(&quoted).count();
    if references != 1 {
        return Err(format!(
            "the js glue names {quoted} {references} times, expected once: did wasm-bindgen change how it loads the wasm?"
        ));
    }
    let js = js.replace(&quoted, &format!("'{wasm_name}'"));
    let js_name = hashed_name("floatball", "js", js.as_bytes());
    let css_name = hashed_name("style", "css", &css);
    let page = render_page(template, &js_name, &wasm_name, &css_name)?;
    Ok(Packaged {
        files: vec![
            (wasm_name.clone(), wasm),
            (js_name.clone(), js.into_bytes()),
            (css_name.clone(), css),
            ("index.html".to_owned(), page.into_bytes()),
        ],
        wasm_name,
        js_name,
        css_name,
    })
}

/// The stylesheet link of the template `static/index.html`.
const TEMPLATE_STYLESHEET: &str = r#"<link rel="stylesheet" href="/style.css">"#;

/// The built page: the template with the hashed stylesheet and, before `</head>`,
/// preloads of the js (which `boot.js` imports by this link) and the wasm.
pub fn render_page(
    template: &str,
    js_name: &str,
    wasm_name: &str,
    css_name: &str,
) -> Result<String, String> {
    for anchor in [TEMPLATE_STYLESHEET, "</head>"] {
        if template.matches(anchor).count() != 1 {
            return Err(format!(
                "static/index.html must contain `{anchor}` exactly once"
            ));
        }
    }
    let preloads = format!(
        "  <link rel=\"modulepreload\" href=\"/pkg/{js_name}\">\n  \
         <link rel=\"preload\" href=\"/pkg/{wasm_name}\" as=\"fetch\" type=\"application/wasm\" crossorigin>\n</head>"
    );
    Ok(template
        .replace(
            TEMPLATE_STYLESHEET,
            &format!(r#"<link rel="stylesheet" href="/pkg/{css_name}">"#),
        )
        .replace("</head>", &preloads))
}

/// The brotli copy of `content` at `quality` (0–11).
pub fn brotli(content: &[u8], quality: u32) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    {
        let mut writer = brotli::CompressorWriter::new(&mut out, 64 * 1024, quality, 22);
        writer
            .write_all(content)
            .map_err(|err| format!("brotli: {err}"))?;
    }
    Ok(out)
}

/// The gzip copy of `content` at `level` (0–9).
pub fn gzip(content: &[u8], level: u32) -> Result<Vec<u8>, String> {
    let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::new(level));
    encoder
        .write_all(content)
        .map_err(|err| format!("gzip: {err}"))?;
    encoder.finish().map_err(|err| format!("gzip: {err}"))
}

/// Replaces `pkg` (build output only) with the packaged files and their `.br` and
/// `.gz` copies, compressing the files in parallel.
pub fn write_pkg(pkg: &Path, packaged: &Packaged, levels: Levels) -> Result<(), String> {
    if pkg.exists() {
        std::fs::remove_dir_all(pkg)
            .map_err(|err| format!("cannot clear {}: {err}", pkg.display()))?;
    }
    std::fs::create_dir_all(pkg)
        .map_err(|err| format!("cannot create {}: {err}", pkg.display()))?;
    let write = |name: &str, content: &[u8]| {
        let path = pkg.join(name);
        std::fs::write(&path, content)
            .map_err(|err| format!("cannot write {}: {err}", path.display()))
    };
    std::thread::scope(|scope| {
        let jobs: Vec<_> = packaged
            .files
            .iter()
            .map(|(name, content)| {
                scope.spawn(move || -> Result<(), String> {
                    write(name, content)?;
                    write(
                        &format!("{name}.br"),
                        &brotli(content, levels.brotli_quality)?,
                    )?;
                    write(&format!("{name}.gz"), &gzip(content, levels.gzip_level)?)
                })
            })
            .collect();
        jobs.into_iter().try_for_each(|job| {
            job.join()
                .map_err(|_| "a compression thread panicked".to_owned())?
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read as _;

    const TEMPLATE: &str = "<html><head>\n  <link rel=\"stylesheet\" href=\"/style.css\">\n</head><body><script type=\"module\" src=\"/boot.js\"></script></body></html>";
    const GLUE: &str = "if (typeof module_or_path === 'undefined') {\n    module_or_path = new URL('floatball_bg.wasm', import.meta.url);\n}";

    #[test]
    fn names_carry_16_hex_digits_of_the_content_hash() {
        let name = hashed_name("floatball", "js", b"abc");
        // SHA-256("abc") starts ba7816bf8f01cfea.
        assert_eq!(name, "floatball-ba7816bf8f01cfea.js");
        assert_ne!(name, hashed_name("floatball", "js", b"abd"));
    }

    #[test]
    fn the_js_loads_the_hashed_wasm_and_the_page_preloads_both() {
        let packaged = package(b"wasm".to_vec(), GLUE, b"css".to_vec(), TEMPLATE).unwrap();
        let file = |name: &str| {
            let (_, content) = packaged
                .files
                .iter()
                .find(|(file, _)| file == name)
                .unwrap();
            String::from_utf8(content.clone()).unwrap()
        };
        let js = file(&packaged.js_name);
        assert!(!js.contains("'floatball_bg.wasm'"), "{js}");
        assert!(js.contains(&format!("'{}'", packaged.wasm_name)), "{js}");
        assert_eq!(
            packaged.js_name,
            hashed_name("floatball", "js", js.as_bytes())
        );
        assert_eq!(
            packaged.wasm_name,
            hashed_name("floatball_bg", "wasm", b"wasm")
        );
        let page = file("index.html");
        assert!(!page.contains("/style.css"), "{page}");
        for expected in [
            format!(
                r#"<link rel="stylesheet" href="/pkg/{}">"#,
                packaged.css_name
            ),
            format!(
                r#"<link rel="modulepreload" href="/pkg/{}">"#,
                packaged.js_name
            ),
            format!(
                r#"<link rel="preload" href="/pkg/{}" as="fetch""#,
                packaged.wasm_name
            ),
        ] {
            assert!(page.contains(&expected), "{expected} in {page}");
        }
        assert!(page.find("modulepreload") < page.find("</head>"), "{page}");
        assert!(page.contains(r#"<script type="module" src="/boot.js">"#));
    }

    #[test]
    fn a_glue_that_names_the_wasm_otherwise_stops_the_build() {
        let error = package(
            b"w".to_vec(),
            "fetch('other.wasm')",
            b"c".to_vec(),
            TEMPLATE,
        )
        .unwrap_err();
        assert!(error.contains("0 times"), "{error}");
        let twice = format!("{GLUE}{GLUE}");
        assert!(package(b"w".to_vec(), &twice, b"c".to_vec(), TEMPLATE).is_err());
        assert!(render_page("<html></html>", "a.js", "b.wasm", "c.css").is_err());
    }

    #[test]
    fn the_real_template_renders() {
        let template =
            std::fs::read_to_string(tools::workspace_root().join("static/index.html")).unwrap();
        let page = render_page(&template, "f-0.js", "g-0.wasm", "s-0.css").unwrap();
        assert!(page.contains(r#"href="/pkg/s-0.css""#), "{page}");
        // The Content-Security-Policy forbids inline scripts: the page adds none.
        assert_eq!(
            page.matches("<script").count(),
            template.matches("<script").count()
        );
        let boot = std::fs::read_to_string(tools::workspace_root().join("static/boot.js")).unwrap();
        assert!(boot.contains("link[rel=\"modulepreload\"]"), "{boot}");
    }

    #[test]
    fn written_copies_decompress_to_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let pkg = dir.path().join("pkg");
        std::fs::create_dir_all(&pkg).unwrap();
        std::fs::write(pkg.join("floatball-0000000000000000.js"), "old build").unwrap();
        let content: Vec<u8> = (0..50_000u32)
            .flat_map(|n| (n % 251).to_le_bytes())
            .collect();
        let packaged = package(content.clone(), GLUE, b"body{}".to_vec(), TEMPLATE).unwrap();
        write_pkg(&pkg, &packaged, Build::Test.levels()).unwrap();
        let mut names: Vec<String> = std::fs::read_dir(&pkg)
            .unwrap()
            .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names.len(), 12, "{names:?}");
        assert!(!names.contains(&"floatball-0000000000000000.js".to_owned()));
        let wasm = pkg.join(&packaged.wasm_name);
        assert_eq!(std::fs::read(&wasm).unwrap(), content);
        let mut unbrotli = Vec::new();
        brotli::Decompressor::new(
            std::fs::File::open(pkg.join(format!("{}.br", packaged.wasm_name))).unwrap(),
            4096,
        )
        .read_to_end(&mut unbrotli)
        .unwrap();
        assert_eq!(unbrotli, content);
        let mut ungzip = Vec::new();
        flate2::read::GzDecoder::new(
            std::fs::File::open(pkg.join(format!("{}.gz", packaged.wasm_name))).unwrap(),
        )
        .read_to_end(&mut ungzip)
        .unwrap();
        assert_eq!(ungzip, content);
    }
}
