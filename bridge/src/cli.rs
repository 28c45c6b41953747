//! The `floatball` command line.
//!
//! `floatball` with no subcommand serves the app and the API with the installation in
//! `--data-dir`; `floatball check` only reads and checks the configuration. Every
//! subcommand is listed by `floatball --help`.

use std::net::SocketAddr;
use std::path::PathBuf;

use anyhow::Context;
use clap::{Parser, Subcommand};

use crate::auth::Clock;
use crate::config::{self, Config, Overrides};
use crate::server;
use crate::state::{AppState, Paths};

/// Floatball's bridge: serves the operator app and relays to the ball matrix.
#[derive(Debug, Parser)]
#[command(name = "floatball", version, about)]
pub struct Cli {
    /// What to do; without a command, serve.
    #[command(subcommand)]
    pub command: Option<Command>,
    /// Address and port to listen on (port 0 picks a free port); overrides `listen` in
    /// floatball.toml.
    #[arg(long)]
    pub listen: Option<SocketAddr>,
    /// A gateway's port, `sim` or a serial device such as /dev/ttyUSB0; the n-th flag
    /// replaces the n-th [[gateway]]'s port in floatball.toml.
    #[arg(long = "gateway", value_name = "PORT")]
    pub gateways: Vec<String>,
    /// Directory for the configuration, the password and the show files.
    #[arg(long, default_value = "data", global = true)]
    pub data_dir: PathBuf,
    /// Directory holding the web app (`index.html` and the built `pkg/`).
    #[arg(long, default_value = "static")]
    pub static_dir: PathBuf,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Check floatball.toml (writing the defaults if it is missing) and exit.
    Check,
}

/// Runs the command the user asked for until it ends or Ctrl-C is pressed.
///
/// # Errors
/// Whatever stops the command, in words for the person who started it.
pub async fn run(cli: Cli) -> anyhow::Result<()> {
    std::fs::create_dir_all(&cli.data_dir).with_context(|| {
        format!(
            "cannot create the data directory {}",
            cli.data_dir.display()
        )
    })?;
    let overrides = Overrides {
        listen: cli.listen,
        gateway_ports: cli.gateways.clone(),
    };
    let config = Config::load_or_create(&cli.data_dir, &overrides)?;
    match cli.command {
        Some(Command::Check) => {
            println!(
                "{} is valid: {} × {} balls on {} gateway(s)",
                cli.data_dir.join(config::FILE_NAME).display(),
                config.matrix.rows,
                config.matrix.cols,
                config.gateways.len()
            );
            Ok(())
        }
        None => serve(config, cli.data_dir, cli.static_dir).await,
    }
}

/// Serves the app and the API until Ctrl-C or SIGTERM.
async fn serve(config: Config, data_dir: PathBuf, static_dir: PathBuf) -> anyhow::Result<()> {
    if !static_dir.join("index.html").is_file() {
        tracing::warn!(
            "{} has no index.html: the app will not load (build it with `cargo xtask run`)",
            static_dir.display()
        );
    }
    let listen = config.listen;
    let state = AppState::open(
        config,
        Paths {
            data_dir,
            static_dir,
        },
        Clock::system(),
    )?;
    let listener = tokio::net::TcpListener::bind(listen)
        .await
        .with_context(|| format!("cannot listen on {listen}"))?;
    let addr = listener
        .local_addr()
        .context("cannot read the listening address")?;
    // The first line on stdout is the URL: people read it, and tests parse it.
    println!("floatball listening on http://{addr}");
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
