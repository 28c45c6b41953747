//! The `floatball` command line.
//!
//! `floatball` with no subcommand serves the app and the API; later subcommands (such as
//! `simulate`) are listed by `floatball --help`.

use std::net::SocketAddr;
use std::path::PathBuf;

use anyhow::Context;
use clap::Parser;

use crate::server;
use crate::state::AppState;

/// The address the bridge listens on unless told otherwise.
pub const DEFAULT_LISTEN: &str = "0.0.0.0:8080";

/// Floatball's bridge: serves the operator app and relays to the ball matrix.
#[derive(Debug, Parser)]
#[command(name = "floatball", version, about)]
pub struct Cli {
    /// Address and port to listen on (port 0 picks a free port).
    #[arg(long, default_value = DEFAULT_LISTEN)]
    pub listen: SocketAddr,
    /// Directory for the configuration, the password and the show files.
    #[arg(long, default_value = "data")]
    pub data_dir: PathBuf,
    /// Directory holding the web app (`index.html` and the built `pkg/`).
    #[arg(long, default_value = "static")]
    pub static_dir: PathBuf,
}

/// Runs the command the user asked for until it ends or Ctrl-C is pressed.
pub async fn run(cli: Cli) -> anyhow::Result<()> {
    std::fs::create_dir_all(&cli.data_dir).with_context(|| {
        format!(
            "cannot create the data directory {}",
            cli.data_dir.display()
        )
    })?;
    if !cli.static_dir.join("index.html").is_file() {
        tracing::warn!(
            "{} has no index.html: the app will not load (build it with `cargo xtask run`)",
            cli.static_dir.display()
        );
    }
    let listener = tokio::net::TcpListener::bind(cli.listen)
        .await
        .with_context(|| format!("cannot listen on {}", cli.listen))?;
    let addr = listener
        .local_addr()
        .context("cannot read the listening address")?;
    // The first line on stdout is the URL: people read it, and tests parse it.
    println!("floatball listening on http://{addr}");
    let state = AppState::new(cli.static_dir);
    server::run(listener, state, shutdown_signal()).await?;
    Ok(())
}

/// Completes when the process is asked to stop (Ctrl-C or SIGTERM).
async fn shutdown_signal() {
    let ctrl_c = async {
        if let Err(err) = tokio::signal::ctrl_c().await {
            tracing::error!("cannot listen for Ctrl-C: {err}");
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let terminate = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut signal) => {
                signal.recv().await;
            }
            Err(err) => {
                tracing::error!("cannot listen for SIGTERM: {err}");
                std::future::pending::<()>().await;
            }
        }
    };
    #[cfg(not(unix))]
    let terminate = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => {}
        () = terminate => {}
    }
    tracing::info!("shutting down");
}
