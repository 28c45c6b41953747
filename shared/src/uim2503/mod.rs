//! UIM2503 RS232→CAN gateways with UFQ750 units: everything of this family in one
//! place (`docs/uim2503.md`).
//!
//! - [`ascii`]: the gateway's ASCII instruction codec (batches, the compact form);
//! - [`feedback`]: the units' feedback frames (acknowledgements, errors, notices);
//! - [`pvt`]: PVT rows and the units' tables;
//! - [`plan`]: a show planned into every unit's rows and each gateway's run mode;
//! - [`stream`] and [`schedule`]: the instruction stream in the fewest bytes, and when
//!   each refill round goes out;
//! - [`player`]: the family's drive under the show sequencer ([`crate::player`]),
//!   with arming, and the [`player::Player`] the tests drive;
//! - [`sim`]: the simulated gateway and its units (the family's twin).

pub mod ascii;
pub mod feedback;
pub mod plan;
pub mod player;
pub mod pvt;
pub mod schedule;
pub mod sim;
pub mod stream;
pub mod stretch;

#[cfg(test)]
mod player_tests;
