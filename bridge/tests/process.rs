//! The `floatball` binary as a process: the first start writes the configuration, and
//! a bad configuration stops the start with the file, line and reason.

use std::process::{Command, Output};

fn floatball(args: &[&str], data_dir: &std::path::Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_floatball"))
        .args(args)
        .arg("--data-dir")
        .arg(data_dir)
        .env("RUST_LOG", "warn")
        .output()
        .expect("run floatball")
}

#[test]
fn the_first_start_writes_the_documented_defaults() {
    let data = tempfile::tempdir().expect("temp dir");
    let output = floatball(&["check"], data.path());
    assert!(output.status.success(), "{output:?}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("10 × 10 balls on 1 gateway(s)"), "{stdout}");
    // The patch of live input, off, the matrix from universe 1, address 1.
    assert!(
        stdout.contains(
            "live input off (Art-Net and sACN; hold after 1000 ms): 100 balls patched on 1 \
             universe(s), universe 1; profile 16-bit position (2 channels)"
        ),
        "{stdout}"
    );
    let written = std::fs::read_to_string(data.path().join("floatball.toml")).expect("written");
    assert_eq!(written, floatball_bridge::config::DEFAULT_FILE);
}

#[test]
fn a_bad_configuration_stops_the_start_naming_file_line_and_reason() {
    let data = tempfile::tempdir().expect("temp dir");
    let path = data.path().join("floatball.toml");
    std::fs::write(
        &path,
        "[matrix]\nrows = 10\n\n[[gateway]]\nport = \"sim\"\nbaud = 50\n",
    )
    .expect("write");
    let output = floatball(&["--listen", "127.0.0.1:0"], data.path());
    assert!(!output.status.success());
    assert!(output.stdout.is_empty(), "it must not start listening");
    let stderr = String::from_utf8_lossy(&output.stderr);
    let expected = format!(
        "floatball: {} line 6, column 8: baud 50 is out of range (1200 to 921600)",
        path.display()
    );
    assert!(stderr.contains(&expected), "{stderr}");

    std::fs::write(&path, "[matrix\nrows = 10\n").expect("write");
    let output = floatball(&["check"], data.path());
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("floatball.toml line 1, column "),
        "{stderr}"
    );
}

#[test]
fn more_gateway_flags_than_gateways_stop_the_start() {
    let data = tempfile::tempdir().expect("temp dir");
    let output = floatball(
        &[
            "--gateway",
            "sim",
            "--gateway",
            "/dev/ttyUSB1",
            "--listen",
            "127.0.0.1:0",
        ],
        data.path(),
    );
    assert!(!output.status.success());
    assert!(output.stdout.is_empty(), "it must not start listening");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("2 --gateway flags given but the file configures 1 [[gateway]]"),
        "{stderr}"
    );
}

#[test]
fn check_lists_every_problem_each_with_its_line() {
    let data = tempfile::tempdir().expect("temp dir");
    let path = data.path().join("floatball.toml");
    std::fs::write(
        &path,
        "[matrix]\nrows = 0\ntravel_mm = -1.0\n\n[[gateway]]\nport = \"sim\"\nbaud = 50\n",
    )
    .expect("write");
    let output = floatball(&["check"], data.path());
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    for expected in [
        "line 2, column 8: rows = 0 must be from 1 to 1000",
        "line 3, column 13: travel_mm = -1 must be a number above 0",
        "line 7, column 8: baud 50 is out of range (1200 to 921600)",
    ] {
        assert!(
            stderr.contains(&format!("{} {expected}", path.display())),
            "{expected} is not in {stderr}"
        );
    }
}
