//! The drive twin: a simulated MOONS' drive, sans-IO — SCL lines and the caller's
//! clock in, answers out, the motor's position exact in between.
//!
//! This module owns:
//! - [`Drive`] ([`drive`]): one drive — parameters (`DI VE AC DE EG MT`), immediate
//!   and buffered commands from a host, the queue and the twelve stored segments
//!   ([`program`]: `QL QS QE QU QX`, `QG QR QJ QC` up to five calls deep), the
//!   command buffer of 63 places (`BS PS CT`), jogs (`CJ`, the `J` register, `CS SJ
//!   SM WM`), each command buffered or immediate as the HCR types it, trapezoid
//!   moves with separate `AC`/`DE` (`FL FP FS`, [`profile`]), `WI WT`, outputs, inputs,
//!   registers and their math, the condition code, `SK ST ME MD`, the status word and
//!   the alarms; answers `%`, `*`, `?` and `XX=value`, after its address on RS-485.
//! - [`Bus`] ([`bus`]): drives sharing one RS-485 line, and the start wire — one
//!   drive's output wired to an input of every drive ([`StartWire`]).
//!
//! Time is the caller's: every call takes `now_us`, and [`Drive::advance`] runs the
//! programs and moves to exactly that time (a program's steps between two events take
//! no time). Where MOONS' documents are silent, the choices are in
//! `docs/protocol-notes.md` §8, "The twin: what a simulated MOONS' drive does".
//!
//! ```
//! use floatball_shared::scl::twin::{Drive, DriveConfig};
//!
//! let mut drive = Drive::new(DriveConfig::default());
//! // Store the seed's feed to length as segment 1 (`QL`, its lines, `QS1`), run it.
//! for line in ["QL", "AC25", "DE25", "VE20", "DI80000", "FL", "QS1"] {
//!     drive.receive_line(line, 0);
//! }
//! // `QX` is buffered (HCR p. 220): answered `*`.
//! assert_eq!(drive.receive_line("QX1", 0).as_deref(), Some("*\r"));
//! drive.advance(10_000_000);
//! assert_eq!(drive.position_counts(), 80_000.0);
//! assert_eq!(drive.receive_line("IP", 10_000_000).as_deref(), Some("IP=80000\r"));
//! ```

pub mod bus;
pub mod drive;
pub mod profile;
pub mod program;
#[cfg(test)]
mod tests;

pub use bus::{Bus, StartWire};
pub use drive::{Drive, DriveConfig, MoveEnd, OutputChange, alarm, status};
pub use profile::Profile;
