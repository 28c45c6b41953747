//! `floatball generate` as a process: a generated show is a valid show file the
//! server accepts, a recipe regenerates the same bytes, `--help` names every pattern
//! and parameter, and clamped values are reported.

use crate::common;

use std::path::Path;
use std::process::{Command, Output};

use axum::http::StatusCode;
use common::Bridge;
use floatball_shared::create::PATTERNS;
use floatball_shared::show::{Limits, Show, validate};

fn floatball(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_floatball"))
        .arg("generate")
        .args(args)
        .output()
        .expect("run floatball")
}

fn path(dir: &Path, name: &str) -> String {
    dir.join(name).to_str().expect("utf-8 path").to_owned()
}

#[tokio::test]
async fn a_generated_wave_is_a_valid_show_the_server_accepts() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = path(dir.path(), "wave.json");
    // The recipe key works as a flag too (`--speed-m-s` is the one `--help` shows).
    let output = floatball(&[
        "wave",
        "--speed_m_s",
        "0.8",
        "--direction",
        "back",
        "--duration-s",
        "20",
        "--out",
        &out,
    ]);
    assert!(output.status.success(), "{output:?}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("100 balls (10 × 10), 22.0 s, 110 rows of 200 ms each"),
        "{stdout}"
    );
    assert!(stdout.contains("it can run"), "{stdout}");
    assert!(output.stderr.is_empty(), "no notes: {output:?}");
    let bytes = std::fs::read(&out).expect("written");
    let show = Show::from_json(std::str::from_utf8(&bytes).expect("utf-8")).expect("a show");
    assert_eq!(show.name, "wave");
    assert_eq!(validate(&show, &Limits::for_layout(10, 10)), []);

    let bridge = Bridge::start().await;
    let token = bridge.operator().await;
    let upload = bridge
        .upload(&token, "wave", "application/json", &bytes)
        .await;
    assert_eq!(upload.status, StatusCode::CREATED, "{:?}", upload.body);
}

#[test]
fn a_recipe_regenerates_the_same_bytes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (first, recipe, second) = (
        path(dir.path(), "first.json"),
        path(dir.path(), "recipe.json"),
        path(dir.path(), "second.json"),
    );
    let output = floatball(&[
        "noise",
        "--seed",
        "42",
        "--rows",
        "6",
        "--cols",
        "8",
        "--pitch-mm",
        "600",
        "--duration-s",
        "8",
        "--row-ms",
        "100",
        "--name",
        "hills",
        "--out",
        &first,
        "--recipe-out",
        &recipe,
    ]);
    assert!(output.status.success(), "{output:?}");
    let text = std::fs::read_to_string(&recipe).expect("recipe");
    assert!(text.contains("\"seed\": 42.0"), "{text}");
    assert!(text.contains("\"row_ms\": 100"), "{text}");
    // The recipe keeps the grid it was made for: no need to give it again.
    assert!(
        text.contains("\"rows\": 6,\n    \"cols\": 8,\n    \"pitch_mm\": 600.0,"),
        "{text}"
    );
    let output = floatball(&["--recipe", &recipe, "--out", &second]);
    assert!(output.status.success(), "{output:?}");
    let (a, b) = (
        std::fs::read(&first).expect("first"),
        std::fs::read(&second).expect("second"),
    );
    assert_eq!(a, b, "the recipe regenerates the same show");
    let show = Show::from_json(std::str::from_utf8(&a).expect("utf-8")).expect("a show");
    assert_eq!((show.name.as_str(), show.layout.pitch_mm), ("hills", 600.0));
    // The command line still wins over the recipe's grid, field by field.
    let output = floatball(&["--recipe", &recipe, "--rows", "3", "--out", &second]);
    assert!(output.status.success(), "{output:?}");
    let text = std::fs::read_to_string(&second).expect("third");
    let show = Show::from_json(&text).expect("a show");
    assert_eq!(
        (show.layout.rows, show.layout.cols, show.layout.pitch_mm),
        (3, 8, 600.0)
    );
}

#[test]
fn a_timeline_with_transitions_renders_within_an_installations_limits() {
    let dir = tempfile::tempdir().expect("temp dir");
    let config = path(dir.path(), "floatball.toml");
    std::fs::write(
        &config,
        "[matrix]\nrows = 4\ncols = 5\npitch_mm = 400.0\ntravel_mm = 3000.0\n\
         max_speed_mm_s = 800.0\nmax_accel_mm_s2 = 1000.0\n\n[[gateway]]\nport = \"sim\"\n",
    )
    .expect("config");
    let recipe = path(dir.path(), "recipe.json");
    std::fs::write(
        &recipe,
        r#"{ "format": "floatball-recipe", "version": 1, "name": "lobby",
             "segments": [
               { "pattern": "wave", "params": { "amplitude_mm": 1500 }, "duration_s": 6, "transition_s": 2 },
               { "pattern": "ripple", "params": {}, "duration_s": 6, "transition_s": 2 },
               { "pattern": "breathe", "params": { "centre_mm": 2000 }, "duration_s": 4 }
             ] }"#,
    )
    .expect("recipe");
    let out = path(dir.path(), "lobby.json");
    let output = floatball(&["--recipe", &recipe, "--config", &config, "--out", &out]);
    assert!(output.status.success(), "{output:?}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("20 balls (4 × 5), "), "{stdout}");
    assert!(stdout.contains("floatball.toml: it can run"), "{stdout}");
    // The wave is too fast for this installation: scaled down, with a note.
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("note: amplitude_mm of wave 1 clamped from 1500 to "),
        "{stderr}"
    );
    // And the transitions are lengthened for this slow installation.
    assert!(
        stderr.contains("note: transition_s of wave 1 clamped from 2 to "),
        "{stderr}"
    );
    let show = Show::from_json(&std::fs::read_to_string(&out).expect("show")).expect("a show");
    assert!(show.duration_ms() > 22_000);
    let mut limits = Limits::for_layout(4, 5);
    (
        limits.travel_mm,
        limits.max_speed_mm_s,
        limits.max_accel_mm_s2,
    ) = (3000.0, 800.0, 1000.0);
    assert_eq!(validate(&show, &limits), []);
}

#[test]
fn help_names_every_pattern_and_parameter() {
    let output = floatball(&["--help"]);
    assert!(output.status.success(), "{output:?}");
    let help = String::from_utf8_lossy(&output.stdout);
    for pattern in PATTERNS {
        assert!(
            help.contains(&format!("  {}: {}", pattern.name, pattern.help)),
            "{help}"
        );
        for param in pattern.params {
            assert!(
                help.contains(&format!("--{} ", param.key.replace('_', "-"))),
                "{}: {help}",
                param.key
            );
        }
    }
    let output = floatball(&["wave", "--help"]);
    let help = String::from_utf8_lossy(&output.stdout);
    assert!(
        help.contains("--speed-m-s <NUMBER>") && help.contains("[m/s, 0–5, default 0.5]"),
        "{help}"
    );
    assert!(
        help.contains("[possible values: right, left, back, front]"),
        "{help}"
    );
    let main = Command::new(env!("CARGO_BIN_EXE_floatball"))
        .arg("--help")
        .output()
        .expect("run floatball");
    assert!(String::from_utf8_lossy(&main.stdout).contains("generate"));
}

#[test]
fn mistakes_are_refused_and_clamps_reported() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = path(dir.path(), "x.json");
    let output = floatball(&["--out", &out]);
    assert!(!output.status.success());
    assert!(
        String::from_utf8_lossy(&output.stderr).contains("give a pattern (wave, ripple"),
        "{output:?}"
    );
    let output = floatball(&["wave", "--size", "3", "--out", &out]);
    assert!(!output.status.success());
    assert!(
        String::from_utf8_lossy(&output.stderr).contains("--size"),
        "{output:?}"
    );
    let output = floatball(&["wave"]);
    assert!(String::from_utf8_lossy(&output.stderr).contains("give --out FILE"));
    // Out of its range: clamped, said on stderr, and the show still written.
    let output = floatball(&[
        "wave",
        "--speed_m_s",
        "9",
        "--duration-s",
        "5",
        "--out",
        &out,
    ]);
    assert!(output.status.success(), "{output:?}");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("note: speed_m_s of wave 1 clamped from 9 to 5 m/s (the range is 0 to 5)"),
        "{stderr}"
    );
    assert!(Path::new(&out).exists());
    // Negative numbers are values, not flags.
    let output = floatball(&["ripple", "--x-m", "-2", "--duration-s", "5", "--out", &out]);
    assert!(output.status.success(), "{output:?}");
    assert!(output.stderr.is_empty(), "{output:?}");
    // Characters the built-in font lacks: drawn as ?, said on stderr.
    let output = floatball(&[
        "text",
        "--text",
        "HI 字",
        "--duration-s",
        "5",
        "--out",
        &out,
    ]);
    assert!(output.status.success(), "{output:?}");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("note: text of text 1: 字 not in the built-in font, drawn as ? (draw them with the bitmap parameter"),
        "{stderr}"
    );
    // A word standing still, wider than the matrix: only its middle shows, said so.
    let output = floatball(&[
        "text",
        "--text",
        "HELLO",
        "--scroll-m-s",
        "0",
        "--rows",
        "10",
        "--cols",
        "10",
        "--duration-s",
        "5",
        "--out",
        &out,
    ]);
    assert!(output.status.success(), "{output:?}");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains(
            "note: text of text 1: 38 balls across on a matrix 10 across, only its middle is shown"
        ),
        "{stderr}"
    );
}
