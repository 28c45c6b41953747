//! The bridge daemon's library: the I/O shell around `floatball_shared`.
//!
//! # Layout
//! - [`cli`]: the command line and what each command does.
//! - [`link`]: the links to the gateways (serial ports, the simulated gateway) with
//!   their e-stop lane.
//! - [`simulate`]: `floatball simulate`, the simulated gateway on a real serial device.
//! - [`server`]: the HTTP server — static app, API routes — and its shutdown.
//! - [`ws`]: the WebSocket endpoint `/ws`: status out, control in.
//! - [`state`]: what every request handler shares (status channel, paths).
#![forbid(unsafe_code)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod cli;
pub mod link;
pub mod server;
pub mod simulate;
pub mod state;
pub mod ws;
