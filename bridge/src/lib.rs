//! The bridge daemon's library: the I/O shell around `floatball_shared`.
//!
//! # Layout
//! - [`cli`]: the command line and what each command does.
//! - [`config`]: `floatball.toml`, written with defaults on first start, checked with
//!   errors that name the line.
//! - [`auth`]: the operator password (argon2id), bearer tokens, the login limit.
//! - [`store`]: the show files on disk, validated before they are stored.
//! - [`playlist`]: the playlist Start plays, stored beside the shows.
//! - [`durable`]: atomic, durable file writes.
//! - [`link`]: the links to the gateways (serial ports, the simulated gateway) with
//!   their e-stop lane.
//! - [`gateways`]: every link together: console lines, the e-stop broadcast, feedback
//!   and link states for the clients.
//! - [`simulate`]: `floatball simulate`, the simulated gateway on a real serial device.
//! - [`playback`]: the player driven by the clock and the links; e-stop straight to
//!   the links.
//! - [`http`]: the HTTP API under `/api`.
//! - [`ws`]: the WebSocket endpoint `/ws`: status and feedback out, control in.
//! - [`server`]: the router (API, WebSocket, static app) and its shutdown.
//! - [`state`]: what every request handler shares.
#![forbid(unsafe_code)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod auth;
pub mod cli;
pub mod config;
pub mod control;
pub mod durable;
pub mod gateways;
pub mod http;
pub mod link;
pub mod playback;
pub mod playlist;
pub mod server;
pub mod simulate;
pub mod state;
pub mod store;
pub mod ws;
