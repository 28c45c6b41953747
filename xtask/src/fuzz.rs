//! `cargo xtask fuzz`: the fuzz targets of the readers of untrusted bytes (the gateway's
//! instruction reader, the simulated gateway behind its line, the feedback decoder, the
//! console parser) at length, in an optimised build. Each target gets `--bytes N`
//! bytes (10 000 000 unless told) and prints bytes/s and what it saw; a failed property
//! panics with the seed that reproduces it.
//!
//! It runs `cargo bench -p floatball-shared --bench fuzz -- --bytes N`; the targets are
//! `shared/tests/fuzz/targets.rs`, which `cargo test` also runs briefly.

use crate::tools::{self, Env};

/// Options of `cargo xtask fuzz`, passed on to the bench.
pub fn parse_options(args: &[String]) -> Result<Vec<String>, String> {
    let mut passed = vec!["--bytes".to_owned(), "10000000".to_owned()];
    let mut iter = args.iter();
    while let Some(arg) = iter.next() {
        let name = arg.as_str();
        match name {
            "--bytes" | "--target" | "--seed" => {
                let value = iter.next().ok_or(format!("{name} needs a value"))?;
                if name != "--target" {
                    value
                        .replace('_', "")
                        .parse::<u64>()
                        .map_err(|err| format!("{name} {value}: {err}"))?;
                }
                if name == "--bytes" {
                    passed.drain(..2);
                }
                passed.extend([name.to_owned(), value.clone()]);
            }
            other => return Err(format!("unknown option {other}")),
        }
    }
    Ok(passed)
}

/// Runs the fuzz targets.
pub fn fuzz(args: &[String]) -> Result<(), String> {
    let passed = parse_options(args)?;
    let root = tools::workspace_root();
    let env = Env::discover(&root)?;
    tools::run_command(
        tools::cargo(&env)
            .args([
                "bench",
                "--package",
                "floatball-shared",
                "--bench",
                "fuzz",
                "--",
            ])
            .args(&passed),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(args: &[&str]) -> Vec<String> {
        args.iter().map(|arg| (*arg).to_owned()).collect()
    }

    #[test]
    fn ten_million_bytes_unless_told() {
        assert_eq!(
            parse_options(&[]).unwrap(),
            strings(&["--bytes", "10000000"])
        );
        assert_eq!(
            parse_options(&strings(&["--bytes", "1_000", "--target", "gateway"])).unwrap(),
            strings(&["--bytes", "1_000", "--target", "gateway"])
        );
    }

    #[test]
    fn refuses_what_it_does_not_know() {
        assert!(parse_options(&strings(&["--bytes"])).is_err());
        assert!(parse_options(&strings(&["--bytes", "many"])).is_err());
        assert!(parse_options(&strings(&["--frobnicate"])).is_err());
    }
}
