//! `floatball`: the bridge daemon. Parses the command line and hands over to the library;
//! everything else lives in `floatball_bridge`.

use std::process::ExitCode;

use clap::FromArgMatches;
use floatball_bridge::cli::Cli;

/// glibc's malloc, set for a daemon with hundreds of threads (two per gateway link)
/// that plans shows of millions of rows on whichever blocking thread is free:
///
/// - `M_ARENA_MAX` = [`MALLOC_ARENAS`] (one): by default each thread that allocates
///   while another holds an arena gets one of its own, up to 8 per core, and memory
///   freed in one arena (a show read and planned on one blocking thread, the report's
///   plan) is not reused by another (the armer's plan on the next): at 10,000 balls
///   the peak was 632 MB with the default, 197 MB with two arenas, 148 MB with one.
///   The many small allocations of the link threads come from glibc's per-thread
///   cache without taking the arena's lock;
/// - `M_MMAP_THRESHOLD` fixed at [`MMAP_THRESHOLD_BYTES`]: a large buffer (an upload,
///   a show's list of tracks) gets pages of its own, returned when freed. Left
///   dynamic, glibc raises the threshold to the largest buffer freed so far (the
///   login's 20 MB password hash at start), and later buffers up to that size stay in
///   the arenas when freed.
///
/// Set before the first thread starts; `MALLOC_ARENA_MAX` etc. in the environment
/// still apply after (glibc reads them at its first allocation, these override them).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn tune_malloc() {
    // SAFETY: `mallopt` only sets glibc's allocator parameters; it is called before
    // any other thread exists, with parameters and values glibc documents.
    unsafe {
        libc::mallopt(libc::M_ARENA_MAX, MALLOC_ARENAS);
        libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn tune_malloc() {}

/// Arenas glibc's malloc may use ([`tune_malloc`]).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const MALLOC_ARENAS: i32 = 1;

/// Allocations from this size on get pages of their own ([`tune_malloc`]), bytes.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const MMAP_THRESHOLD_BYTES: i32 = 256 * 1024;

fn main() -> ExitCode {
    tune_malloc();
    let matches = floatball_bridge::cli::command().get_matches();
    if let Some(("generate", generate)) = matches.subcommand() {
        return match floatball_bridge::generate::run(generate) {
            Ok(()) => ExitCode::SUCCESS,
            Err(err) => {
                eprintln!("floatball: {err:#}");
                ExitCode::FAILURE
            }
        };
    }
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(err) => err.exit(),
    };
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_writer(std::io::stderr)
        .init();
    let runtime = match tokio::runtime::Runtime::new() {
        Ok(runtime) => runtime,
        Err(err) => {
            eprintln!("floatball: cannot start the async runtime: {err}");
            return ExitCode::FAILURE;
        }
    };
    match runtime.block_on(floatball_bridge::cli::run(cli)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("floatball: {err:#}");
            ExitCode::FAILURE
        }
    }
}
