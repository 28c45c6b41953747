//! Golden wire files (`bridge/tests/golden/`): what a fixed show puts on the wire,
//! compared line by line. Shared by the integration tests (`common::golden`) and the
//! bridge's own unit tests (`src/mbox_tests.rs`, by path).

/// Compares `actual` with the golden file `name` in `bridge/tests/golden/` line by
/// line and names the first line that differs, printing the whole record. With
/// `FLOATBALL_BLESS=1` the file is written from `actual` instead: only ever from code
/// whose wire is known to be right, and read the diff.
pub fn assert_golden(name: &str, actual: &str) {
    let path = format!("{}/tests/golden/{name}", env!("CARGO_MANIFEST_DIR"));
    if std::env::var_os("FLOATBALL_BLESS").is_some() {
        std::fs::write(&path, actual).expect("the golden file written");
        return;
    }
    let expected = std::fs::read_to_string(&path).unwrap_or_else(|error| {
        panic!("{path}: {error}; write it with FLOATBALL_BLESS=1\nactual:\n{actual}")
    });
    let mut expected_lines = expected.lines();
    let mut actual_lines = actual.lines();
    for number in 1.. {
        match (expected_lines.next(), actual_lines.next()) {
            (None, None) => break,
            (expected, got) if expected == got => {}
            (expected, got) => panic!(
                "{name}: line {number} differs on the wire\n  expected: {}\n  actual:   {}\n\
                 the whole record (FLOATBALL_BLESS=1 writes it):\n{actual}",
                expected.unwrap_or("(nothing: the file ended)"),
                got.unwrap_or("(nothing: the record ended)"),
            ),
        }
    }
    assert_eq!(expected, actual, "{name}: same lines, other line ends");
}
