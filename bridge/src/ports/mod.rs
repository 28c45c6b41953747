//! Where the bytes go: one port per drive family and transport, each owned by its own
//! thread or task and woken by the e-stop latch ([`crate::estop::StopPort`]), each
//! handing the playback task ([`crate::playback`]) what its units answered.
//!
//! - [`uim2503`]: the links to UIM2503 gateways — a serial port, a serial device
//!   server over TCP (raw or RFC 2217), or the simulated gateway — with their bulk
//!   and priority lanes, pacing, the greeting and the line-speed change;
//! - [`mbox`]: the MBOX boxes of an installation on one UDP socket, their frames sent
//!   at their slots;
//! - [`scl`]: the links to MOONS' drives in SCL (an RS-485 line or eSCL on UDP), with
//!   their status polls, console and the programs' compilation settings.

pub mod mbox;
pub mod scl;
pub mod uim2503;
