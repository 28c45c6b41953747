//! SCL, the serial command language of MOONS' (Applied Motion) stepper and servo
//! drives, and eSCL, the same over UDP (a Chinese MOONS' article on Q programming is
//! the authority; the facts it does not give are checked against MOONS' Host Command
//! Reference in `docs/protocol-notes.md`, "MOONS' SCL"). No sockets or serial ports
//! here: text and bytes in, text and bytes out.
//!
//! This module owns:
//! - [`Command`]: every command the seed's Q programs use (`FL FP FS DI VE AC DE EG SP
//!   WI WT QG QR QJ TI TR CR QC MT SO`, `R+ R- R* R/ R| R&`, `RX RM`), what a host
//!   needs to run drives safely (`SK ST ME MD IP EP SC AL AR QL QS QX QE QU`), to
//!   stream a command buffer (`BS PS CT`) and to jog (`JS JA JL CJ CS SJ`, and in
//!   programs `RXJ SM WM`), typed with units (`DI` counts, `VE` rev/s, `AC`/`DE`
//!   rev/s², `WT` s); a value of `None` is the query form (`VE` alone asks). Its text
//!   is `Display` ([`command`]); [`Command::kind`] is its type in MOONS' Host Command
//!   Reference — buffered or immediate — which decides whether a program may hold it.
//! - [`Request`]: a command with the optional RS-485 [`Address`] before it, its wire
//!   form with the carriage return ([`Request::to_wire`]), and [`parse_script`] /
//!   [`Request::parse`] for command lines ([`parse`]).
//! - [`Reply`] and [`Answer`]: the drive's `%`, `*`, `?code` and `XX=value`, with the
//!   address a drive on a shared line puts first, and [`QueueUpload`], the lines after
//!   the `%` of a `QU` ([`response`]).
//! - [`twin`]: a simulated drive and a bus of them (the drive twin).
//! - eSCL: [`Request::to_escl`], [`Reply::from_escl`], … with the header
//!   [`escl::HEADER`] and the port [`escl::UDP_PORT`] ([`escl`]).
//!
//! - [`units`]: what a drive holds of the numbers it is sent (`VE`, `AC`/`DE`, `WT`:
//!   steps and ranges), which the compiler writes and the twin runs.
//! - [`qprogram`]: a show's track compiled to a Q program a drive stores and runs
//!   (segments of `FP` moves, `WT` rests, the start input), with its deviation report.
//!
//! Every refusal is typed and says where ([`ParseError`]: line and column;
//! [`EsclError`]); no input panics a parser; whatever is accepted prints back exactly
//! as it was read (numbers have one canonical form: no `+`, no leading zeros, no `-0`).
//!
//! # Example
//! ```
//! use floatball_shared::scl::{
//!     Address, Answer, Command, Decimal, Reply, Request, escl, parse_script,
//! };
//!
//! // The seed's feed to length: wait for a falling edge on input 3, then 4 turns.
//! let program = parse_script("WI3F\nVE20\nDI32000\nFL").unwrap();
//! assert_eq!(program[1].command, Command::Velocity { rev_s: Some(Decimal::from_int(20)) });
//! assert_eq!(program[2].to_wire(), b"DI32000\r");
//!
//! // Drive "1" on an RS-485 line refuses a velocity out of range.
//! let request = Request::to(Address::new('1').unwrap(), Command::Velocity {
//!     rev_s: Some(Decimal::from_int(200)),
//! });
//! assert_eq!(request.to_string(), "1VE200");
//! let reply = Reply::parse("1?5\r").unwrap();
//! assert_eq!(reply.answer, Answer::Refused { code: Some(5) });
//!
//! // The same over Ethernet: header 00 07, the text, CR.
//! let query = Request::new(Command::ImmediatePosition).to_escl();
//! assert_eq!(query, [0x00, 0x07, b'I', b'P', b'\r']);
//! assert_eq!(escl::UDP_PORT, 7775);
//! ```

pub mod command;
pub mod drive;
mod error;
pub mod escl;
pub mod parse;
pub mod qprogram;
pub mod response;
#[cfg(test)]
mod tests;
pub mod twin;
pub mod units;

pub use command::{
    Address, Command, Decimal, InputCondition, IoPoint, JumpCondition, Kind, Level, MathOp, QLine,
    Register, Request, Segment, StopRate,
};
pub use error::{EsclError, ParseError, ParseErrorKind};
pub use parse::parse_script;
pub use response::{Answer, QueueUpload, Reply, UploadHeader};

/// The carriage return that ends every command and answer.
pub const CR: u8 = b'\r';

/// A line's bytes on a serial line: its text and a carriage return.
fn wire(line: &impl std::fmt::Display) -> Vec<u8> {
    let mut wire = line.to_string().into_bytes();
    wire.push(CR);
    wire
}
