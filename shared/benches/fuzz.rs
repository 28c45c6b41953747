//! The fuzz targets at length: every target (`tests/fuzz/targets.rs`) on a stream of
//! at least `--bytes N` bytes (10 000 000 unless told), seed after seed, printing
//! bytes/s and what each target saw. A failed property panics with its seed.
//!
//! Run with `cargo bench -p floatball-shared --bench fuzz -- --bytes 10000000`, or
//! `cargo xtask fuzz --bytes 10000000`. `--target NAME` runs one target only,
//! `--seed S` starts from another seed.

#[path = "../tests/fuzz/targets.rs"]
mod targets;

use std::time::Instant;

/// Bytes per seed: each seed starts a fresh reader, gateway or decoder.
const BYTES_PER_SEED: usize = 1 << 20;

struct Options {
    bytes: usize,
    target: Option<String>,
    seed: u64,
}

fn options() -> Result<Options, String> {
    let mut options = Options {
        bytes: 10_000_000,
        target: None,
        seed: 1,
    };
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = |name: &str| args.next().ok_or(format!("{name} needs a value"));
        match arg.as_str() {
            "--bytes" => {
                options.bytes = value("--bytes")?
                    .replace('_', "")
                    .parse()
                    .map_err(|err| format!("--bytes: {err}"))?;
            }
            "--target" => options.target = Some(value("--target")?),
            "--seed" => {
                options.seed = value("--seed")?
                    .parse()
                    .map_err(|err| format!("--seed: {err}"))?;
            }
            // `cargo bench` passes `--bench`; other harness options do not apply.
            "--bench" => {}
            other => return Err(format!("unknown option {other}")),
        }
    }
    Ok(options)
}

fn main() {
    let options = match options() {
        Ok(options) => options,
        Err(message) => {
            eprintln!("fuzz: {message}\nusage: fuzz [--bytes N] [--target NAME] [--seed S]");
            std::process::exit(2);
        }
    };
    for (name, target) in targets::TARGETS {
        if options
            .target
            .as_deref()
            .is_some_and(|wanted| wanted != name)
        {
            continue;
        }
        let started = Instant::now();
        let mut total = targets::Report::default();
        let mut seed = options.seed;
        while (total.bytes as usize) < options.bytes {
            let budget = BYTES_PER_SEED.min(options.bytes - total.bytes as usize);
            total.absorb(&target(seed, budget));
            seed += 1;
        }
        let seconds = started.elapsed().as_secs_f64();
        let counts: Vec<String> = total
            .counts
            .iter()
            .map(|(name, count)| format!("{name} {count}"))
            .collect();
        println!(
            "fuzz {name:<8} {} bytes, seeds {}..{}, {:.2} s, {:.2} MB/s; {}",
            total.bytes,
            options.seed,
            seed,
            seconds,
            total.bytes as f64 / seconds / 1e6,
            counts.join(", ")
        );
    }
}
