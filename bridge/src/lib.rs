//! The bridge daemon's library: the I/O shell around `floatball_shared`.
//!
//! # Concurrency rule
//! Each piece of mutable state has **one owner**, and everyone else gets snapshots:
//! - a link's queues and counters belong to its writer thread ([`ports::uim2503`]); handles hand
//!   batches over through a channel, read atomics, and read the link's status as a
//!   copy;
//! - the status every client sees belongs to the playback task ([`playback`]), which
//!   alone writes it;
//! - the e-stop is a latch of atomics ([`estop`]): pressing it takes no lock, awaits
//!   nothing and needs no task or blocking thread — it bumps a generation and wakes
//!   every link's writer, which writes the stop before its next instruction.
//!
//! No lock is held across another lock, an `.await`, or a call into another
//! component; a guard is taken, the value copied out, and the guard dropped at once.
//! Slow work (planning a show, reading files, password hashing) runs on blocking
//! threads, never on the async workers or in the playback task.
//!
//! # Layout
//! - [`cli`]: the command line and what each command does.
//! - [`generate`]: `floatball generate`, shows from patterns or recipes on the command
//!   line, its options built from the patterns' table.
//! - [`config`]: `floatball.toml` (its defaults in `config/default.toml`, written on
//!   first start), parsed (`config/raw.rs`) and checked (`config/check.rs`, the one
//!   place the installation is checked) straight into the shared
//!   [`Installation`](floatball_shared::plan::Installation), with errors that name the
//!   line and column.
//! - [`auth`]: the operator password (argon2id), bearer tokens, the login limit.
//! - [`store`]: the show files on disk; shows go in and come out as `Show`s, read
//!   through `floatball_shared::show::import`.
//! - [`playlist`]: the playlist Start plays, stored beside the shows.
//! - [`durable`]: atomic, durable file writes.
//! - [`ports`]: where the bytes go, one port per family and transport, each with its
//!   e-stop lane: [`ports::uim2503`] the links to UIM2503 gateways (serial ports,
//!   serial device servers over TCP or RFC 2217, the simulated gateway) with the
//!   greeting that tells whether a gateway answers and the line-speed change;
//!   [`ports::mbox`] the MBOX boxes of an installation on one UDP socket (the sender
//!   is woken by the e-stop like a link's writer); [`ports::scl`] the links to MOONS'
//!   drives in SCL (an RS-485 line or eSCL on UDP), one owner thread each, with their
//!   e-stop (`SK` to every drive), status polls and console.
//! - [`estop`]: the e-stop latch and the one path that presses it, over every port a
//!   stop goes to (`StopPort`: a UIM2503 link, the MBOX boxes, the MOONS' drives).
//! - [`gateways`]: every link together: console lines and feedback for the clients.
//! - [`commission`]: commissioning a UIM2503 gateway's units: roll call, assignment of
//!   stations by serial, identify moves, and the unit health monitor whose snapshot
//!   the status carries; the simulated units' stations kept in the data directory.
//! - [`simulate`]: `floatball simulate`, the simulated gateway on a real serial device,
//!   and ([`simulate::mbox`]) simulated MBOX boxes on real UDP sockets, and
//!   ([`simulate::scl`]) simulated MOONS' drives on a serial device or eSCL UDP;
//!   ([`simulate::tcp`]) simulated gateways on TCP sockets, as behind device servers.
//! - [`playback`]: the show sequencer (`floatball_shared::player`) driven by the clock
//!   and the ports, the owner of the status, in one task for every family
//!   (`playback/sequenced.rs`): UIM2503 gateways on their links with the link
//!   watchdog (`playback/uim2503.rs`), MBOX boxes (`playback/mbox.rs`), MOONS' drives
//!   (`playback/scl.rs`).
//! - [`control`]: Start, Reset and Home as the WebSocket asks for them.
//! - [`osc`]: show control over OSC on UDP (`[osc]`, off by default): commands from
//!   the allowed senders carried out by the same functions as the WebSocket's, and
//!   feedback of the state, the entry and the show time.
//! - [`schedule`]: the weekly schedule: `<data-dir>/schedule.json`, and the one
//!   scheduler task that starts the playlist in its windows and ends them (home,
//!   motors off), never releasing an e-stop nor clearing an error.
//! - [`timecode`]: timecode chase (`[timecode]`, off by default): Art-Net or MIDI
//!   timecode in, the playlist started and located in step through
//!   [`control::issue_unless_latched`].
//! - [`live`]: live input's receivers (`[live] enabled`): Art-Net (one socket with
//!   the timecode chase's) and sACN in, merged and patched into each ball's target,
//!   published as a [`live::LiveInput`] snapshot for the live mode; counters and
//!   `GET /api/live/status`.
//! - [`install`]: a new installation (`PUT /api/installation`, a gateway's line
//!   speed) checked, saved into `floatball.toml` (`config/edit.rs`) and applied while
//!   idle, without a restart.
//! - [`arming`]: while idle, the playlist's first entry loaded ahead of Start, and the
//!   one `disarm` entry point.
//! - [`http`]: the HTTP API under `/api`.
//! - [`origin`]: which browser origins may call the API (CORS) and open the WebSocket;
//!   the configuration's `allowed_origins` are normalised by it when checked.
//! - [`ws`]: the WebSocket endpoint `/ws`: status and feedback out, control in.
//! - [`server`]: the router (API, WebSocket, static app) and its shutdown.
//! - [`state`]: what every request handler shares.
#![forbid(unsafe_code)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod arming;
pub mod auth;
pub mod cli;
pub mod commission;
pub mod config;
pub mod control;
pub mod durable;
pub mod estop;
pub mod gateways;
pub mod generate;
pub mod http;
pub mod install;
pub mod live;
pub mod origin;
pub mod osc;
pub mod playback;
pub mod playlist;
pub mod ports;
pub mod schedule;
pub mod server;
pub mod simulate;
pub mod state;
pub mod store;
pub mod timecode;
pub mod ws;
