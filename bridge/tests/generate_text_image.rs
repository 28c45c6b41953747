//! `floatball generate` as a process for the text and picture patterns: a PNG file's
//! path becomes its heights and a show the server accepts, the picture travels in the
//! recipe and regenerates the same bytes, words scroll either way, and a file that is
//! not a picture is refused in words.

use crate::common;

use std::io::Cursor;
use std::path::Path;
use std::process::{Command, Output};

use axum::http::StatusCode;
use common::Bridge;
use floatball_shared::show::{Limits, Show, validate};
use image::{DynamicImage, ImageBuffer, ImageFormat, Luma};

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

/// A 100 × 10 grey PNG brightening left to right: pixel x is 30 + 2x.
fn gradient_png(dir: &Path) -> String {
    let picture = ImageBuffer::from_fn(100, 10, |x, _| {
        Luma([u8::try_from(30 + 2 * x).expect("below 255")])
    });
    let mut bytes = Vec::new();
    DynamicImage::ImageLuma8(picture)
        .write_to(&mut Cursor::new(&mut bytes), ImageFormat::Png)
        .expect("encode");
    let file = path(dir, "gradient.png");
    std::fs::write(&file, bytes).expect("write the picture");
    file
}

fn read_show(file: &str) -> (Vec<u8>, Show) {
    let bytes = std::fs::read(file).expect("written");
    let show = Show::from_json(std::str::from_utf8(&bytes).expect("utf-8")).expect("a show");
    (bytes, show)
}

#[tokio::test]
async fn a_picture_file_becomes_its_heights_and_a_show_the_server_accepts() {
    let dir = tempfile::tempdir().expect("temp dir");
    let picture = gradient_png(dir.path());
    let out = path(dir.path(), "gradient.json");
    let output = floatball(&[
        "image",
        "--image",
        &picture,
        "--rows",
        "1",
        "--cols",
        "10",
        "--duration-s",
        "10",
        "--out",
        &out,
    ]);
    assert!(output.status.success(), "{output:?}");
    assert!(output.stderr.is_empty(), "no notes: {output:?}");
    let (_, show) = read_show(&out);
    assert_eq!(validate(&show, &Limits::for_layout(1, 10)), []);
    // Ten columns of ten pixels: column c averages 39 + 20c, bright (2000 mm) high and
    // dark (4000 mm) low. Halfway through, every ball stands at its column's height.
    let row = show.tracks[0].rows.len() / 2;
    for (col, track) in show.tracks.iter().enumerate() {
        let level = (39.0 + 20.0 * col as f64) / 255.0;
        let want_mm = 4000.0 - 2000.0 * level;
        let mm = track.rows[row].position_mm;
        assert!(
            (mm - want_mm).abs() <= 0.05 + 1e-9,
            "column {col}: {mm} mm, want {want_mm}"
        );
    }

    // On the server's 10 × 10 matrix, a show it accepts.
    let output = floatball(&[
        "image",
        "--image",
        &picture,
        "--duration-s",
        "10",
        "--out",
        &out,
    ]);
    assert!(output.status.success(), "{output:?}");
    let (bytes, _) = read_show(&out);
    let bridge = Bridge::start().await;
    let token = bridge.operator().await;
    let upload = bridge
        .upload(&token, "gradient", "application/json", &bytes)
        .await;
    assert_eq!(upload.status, StatusCode::CREATED, "{:?}", upload.body);
}

#[test]
fn the_picture_travels_in_the_recipe_and_regenerates_the_same_bytes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let picture = gradient_png(dir.path());
    let (out, recipe, again) = (
        path(dir.path(), "a.json"),
        path(dir.path(), "a.recipe.json"),
        path(dir.path(), "b.json"),
    );
    let output = floatball(&[
        "image",
        "--image",
        &picture,
        "--fit",
        "cover",
        "--reveal_s",
        "3",
        "--rows",
        "3",
        "--cols",
        "4",
        "--duration-s",
        "6",
        "--out",
        &out,
        "--recipe-out",
        &recipe,
    ]);
    assert!(output.status.success(), "{output:?}");
    let text = std::fs::read_to_string(&recipe).expect("recipe");
    // The PNG's signature, in base64.
    assert!(text.contains("\"image\": \"iVBORw0KGgo"), "{text}");
    // A recipe holds no grid: the same one is given again.
    let output = floatball(&[
        "--recipe", &recipe, "--rows", "3", "--cols", "4", "--out", &again,
    ]);
    assert!(output.status.success(), "{output:?}");
    assert_eq!(
        std::fs::read(&out).expect("first"),
        std::fs::read(&again).expect("second")
    );
}

#[test]
fn words_and_bitmaps_scroll_either_way_from_the_command_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = path(dir.path(), "t.json");
    for args in [
        &["--text", "Hi 5!", "--scroll_m_s", "-0.3"][..],
        &[
            "--bitmap",
            "#.#|.#.|#.#",
            "--scroll_m_s",
            "0.3",
            "--style",
            "lowered",
        ],
        // Standing, two glyphs that fit 10 balls across (OK, 15 across, would show
        // only its middle, with a note).
        &["--text", "I!", "--scroll_m_s", "0"],
    ] {
        let mut all = vec!["text", "--duration-s", "8", "--out", &out];
        all.extend_from_slice(args);
        let output = floatball(&all);
        assert!(output.status.success(), "{args:?}: {output:?}");
        assert!(output.stderr.is_empty(), "{args:?}: no notes: {output:?}");
        let (_, show) = read_show(&out);
        assert_eq!(validate(&show, &Limits::for_layout(10, 10)), []);
        // Some balls stand out from the background (3000 mm) halfway through.
        let row = show.tracks[0].rows.len() / 2;
        assert!(
            show.tracks
                .iter()
                .any(|track| (track.rows[row].position_mm - 3000.0).abs() > 100.0),
            "{args:?}"
        );
    }
}

#[test]
fn a_file_that_is_not_a_picture_is_refused_in_words() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = path(dir.path(), "x.json");
    let not_a_picture = path(dir.path(), "notes.txt");
    std::fs::write(&not_a_picture, "not a picture").expect("write");
    let output = floatball(&["image", "--image", &not_a_picture, "--out", &out]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains(
            "the picture in \"image\" cannot be read (it is neither a PNG nor a JPEG \
             picture); use a PNG or JPEG file"
        ),
        "{stderr}"
    );
    assert!(!Path::new(&out).exists());
    let output = floatball(&["image", "--out", &out]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("no picture was given"), "{stderr}");
}
