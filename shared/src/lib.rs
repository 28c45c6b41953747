//! Floatball's protocol core: everything that must behave identically in the bridge
//! (native) and in the web app (wasm32).
//!
//! No I/O and no clocks live here ("sans-IO"): time is always a parameter and bytes come
//! in and go out as buffers, so the same code runs on a show controller PC, in a phone's
//! browser and in tests.
//!
//! # Layout
//! - [`api`]: the JSON messages of the HTTP and WebSocket API (`docs/architecture.md` §4), shared by the
//!   bridge and the app so both sides agree on every field.
//! - [`codes`]: the stable error codes (and their parameters) of every refusal,
//!   validation problem and parse error, enumerable for the translation tests.
//! - [`create`]: show creation: patterns (wave, ripple, rain, plane, breathing
//!   surface, noise, text, picture) described as data for the app's sliders and the
//!   CLI, recipes (a timeline of segments with transitions, as JSON) and their
//!   rendering into a show within the installation's limits by construction.
//! - [`live`]: live input: Art-Net and sACN receivers, the merge of their sources, the
//!   patch of balls to DMX slots, the motion filter within the installation's limits
//!   and the recording of live motion as a show.
//! - [`mod@line`]: a serial line's timing (8N1: 10 bit times a byte): byte time, bytes per
//!   second, time for N bytes — used by the planner, the player, the simulator and the
//!   bridge's pacer.
//! - [`mbox`]: the MBOX motion controller's UDP protocol: typed motion frames (3, 6 or
//!   10 axes, absolute or relative time) and register reads, replies and writes (e-stop,
//!   reset, effects, the box's IP), their big-endian encoder and a decoder that refuses
//!   what the document makes invalid; and [`mbox::twin`], a simulated box (registers,
//!   replies, axes moving over each frame's time, e-stop, counters), and
//!   [`mbox::console`], the operator's text syntax for register operations.
//! - [`motion`]: the one evaluation of a PVT row as a cubic Hermite segment
//!   ([`motion::Segment`]), shared by every family, validation and the preview; and
//!   motion profiles outside the PVT table — point-to-point moves
//!   ([`motion::Trapezoid`]) and braking — used by the player's timing and the simulator.
//! - [`plan`]: the installation (gateways, kinds of drive, which unit hangs where),
//!   the gateways' `port` settings, and the bandwidth / feasibility report with its
//!   coded verdict (why a show cannot run, what would make it run).
//! - [`player`]: the show sequencer — the playlist, approach, load, start, cycles,
//!   E-stop, Reset and Home written once for every drive family, each family a
//!   [`player::Drive`] under it (UIM2503 gateways: [`uim2503::player`]; MBOX boxes:
//!   [`mbox::drive`]; MOONS' drives: [`scl::drive`]).
//! - [`playlist`]: the playlist's limits and the one check of its ranges, used by the
//!   bridge and the app alike.
//! - [`schedule`]: the weekly schedule (windows per weekday in local time, dated
//!   exceptions), its checks, and the decision of what to do at a given local time.
//! - [`scl`]: MOONS' drives' serial command language: typed commands with units and
//!   their text, the drives' answers (`%`, `*`, `?code`, `XX=value`), RS-485 address
//!   characters, eSCL datagrams (UDP), and the parser for command lines and answers;
//!   and [`scl::twin`], a simulated drive (queue, segments, trapezoid moves, I/O,
//!   registers, alarms) and a bus of them with the start wire.
//! - [`show`]: the show model and its native file format, CSV keyframe import,
//!   validation against an installation's limits, sampling for the preview, and the
//!   demo wave the tests and benches share ([`show::demo`]).
//! - [`timecode`]: timecode chase — frame rates and timecode ↔ ms (drop-frame
//!   correct), Art-Net's OpTimeCode, MIDI timecode, and the chase state machine.
//! - [`uim2503`]: UIM2503 gateways with UFQ750 units, the whole family: the ASCII
//!   instruction language ([`uim2503::ascii`]) and the binary feedback frames
//!   ([`uim2503::feedback`]), PVT rows and tables ([`uim2503::pvt`]), the planner
//!   ([`uim2503::plan`]), the instruction stream and its refill schedule, the drive
//!   under the sequencer ([`uim2503::player`]), and the simulated gateway and its units
//!   ([`uim2503::sim`]).

#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod api;
pub mod codes;
pub mod create;
pub mod line;
pub mod live;
pub mod mbox;
pub mod motion;
pub mod plan;
pub mod player;
pub mod playlist;
pub mod schedule;
pub mod scl;
pub mod show;
pub mod timecode;
pub mod uim2503;
