//! The operator's console on MBOX boxes: a small line language for register reads and
//! writes, its parser to the codec's typed datagrams ([`parse`]), the one canonical
//! text of every parsed operation ([`Operation`]'s `Display`, which parses back to the
//! same operation) and the text of a box's reply ([`render_reply`]). Sans-IO and on
//! wasm32 too: the bridge parses and sends, the web app can check a line before it
//! sends it; both print replies the same way.
//!
//! # Syntax
//! One command a line or between `;`; `#` starts a comment to the end of the line;
//! keywords and banks in any case; numbers in decimal or `0x` hex. Register addresses
//! are the document's names read as hex: FN020 is `0x20`, DN1F is `0x1F`.
//!
//! | command | sends |
//! |---|---|
//! | `read FN 0x20 4`, `read DN 0x10 16` | a read (`0x1101`) of *count* registers from *start* |
//! | `write FN 0x0090 1`, `write FN 0x20 192 168 15 201` | a write (`0x1201`), FN not saved (channel 0), one value a register from *start* on |
//! | `write CX 1 0xFFFF` | a write of CX command registers (channel 2) |
//! | `save FN 0x20 192 168 15 201` | a write of FN parameters, saved (channel 1) |
//! | `estop`, `release` | FN `0x0090` = 1, = 0 (not saved) |
//! | `reset` | CX 0 = 0 |
//! | `effects 0xFFFF` | CX 1 = the mask |
//! | `ip 192.168.15.210` | FN020–FN023 = the four octets, saved |
//!
//! A command goes to the route the caller gives (the console's selected box) unless it
//! starts with a box: `@201` (the last octet; the third is the selected box's), `@15.201`
//! (the last two octets, which are the address in a datagram), `@192.168.15.201`, or
//! `@all`; that box executes and replies. `/` and a second box name another replier:
//! `@all/none` (every box executes, none replies), `@15.201/15.202`.
//!
//! # Example
//! ```
//! use floatball_shared::mbox::console::{Operation, ReplyLayout, parse, render_reply};
//! use floatball_shared::mbox::{
//!     BoxAddress, ReadBank, RegisterBlock, RegisterReply, RegisterWrite, Route,
//! };
//!
//! let selected = Route::to(BoxAddress::from_octets(15, 201));
//! let operations = parse("read FN 0x20 4  # the IP\n@all/none estop", selected).unwrap();
//! assert_eq!(operations[0].to_string(), "@15.201 read FN 0x0020 4");
//! assert_eq!(
//!     operations[1],
//!     Operation::Write(RegisterWrite::estop(Route::BROADCAST_SILENT))
//! );
//!
//! let error = parse("read FX 0x20 4", selected).unwrap_err();
//! assert_eq!(
//!     error.to_string(),
//!     "line 1, column 6: expected a register bank FN, DN or CX, found `FX`"
//! );
//!
//! let reply = RegisterReply {
//!     bank: ReadBank::Fn,
//!     route: Route::REPLY,
//!     block: RegisterBlock::new(0x20, vec![192, 168, 15, 201]).unwrap(),
//! };
//! assert_eq!(
//!     render_reply(&reply, ReplyLayout::Line),
//!     "FN0020..FN0023 = 192 168 15 201"
//! );
//! ```

use std::fmt;
use std::net::Ipv4Addr;

use thiserror::Error;

use crate::codes::{Code, Coded, Params};
use crate::params;

use super::error::RangeError;
use super::register::{CX_EFFECTS, FN_IP, MAX_REGISTERS};
use super::{
    BoxAddress, Datagram, ReadBank, RegisterBlock, RegisterRange, RegisterRead, RegisterReply,
    RegisterWrite, Route, WriteBank,
};

/// The console's commands, as the parser knows them (lower case; any case is read).
pub const COMMANDS: [&str; 8] = [
    "read", "write", "save", "estop", "release", "reset", "effects", "ip",
];

/// One parsed console command: the datagram it sends.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Operation {
    /// A register read (`0x1101`); the box answers with a [`RegisterReply`].
    Read(RegisterRead),
    /// A register write (`0x1201`), the named operations included.
    Write(RegisterWrite),
}

impl Operation {
    /// Whether it may go while the e-stop is latched: a read, or the e-stop itself —
    /// the one "inert while latched" rule of MBOX boxes.
    #[must_use]
    pub fn is_inert(&self) -> bool {
        match self {
            Self::Read(_) => true,
            Self::Write(write) => write.is_estop(),
        }
    }

    /// Who executes it and who replies.
    #[must_use]
    pub fn route(&self) -> Route {
        match self {
            Self::Read(read) => read.route,
            Self::Write(write) => write.route,
        }
    }
}

impl From<Operation> for Datagram {
    fn from(operation: Operation) -> Self {
        match operation {
            Operation::Read(read) => Self::Read(read),
            Operation::Write(write) => Self::Write(write),
        }
    }
}

/// Why console text is refused, and where: the 1-based line and column (in characters)
/// of the first thing that is wrong.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Error)]
#[error("line {line}, column {column}: {kind}")]
pub struct ConsoleError {
    /// The line, from 1; lines end with LF (a CR before it is a space).
    pub line: u32,
    /// The column, from 1, in characters; just after the command when something is
    /// missing at its end.
    pub column: u32,
    /// What is wrong.
    pub kind: ConsoleErrorKind,
}

/// A part of a command, for the messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Operand {
    /// A register bank: FN, DN or CX.
    Bank,
    /// The first register's address.
    Start,
    /// How many registers a read asks for.
    Count,
    /// A register's value.
    Value,
    /// The effects mask.
    Mask,
    /// An octet of a box's address after `@`.
    Octet,
    /// The box's new IP address.
    Ip,
}

impl Operand {
    /// What it takes, in words.
    fn range(self) -> String {
        match self {
            Self::Bank => "FN, DN or CX".to_owned(),
            Self::Start => "addresses run from 0 to 0xFFFF".to_owned(),
            Self::Count => format!("one datagram reads 1 to {MAX_REGISTERS} registers"),
            Self::Value | Self::Mask => "a register holds 0 to 65535 (0xFFFF)".to_owned(),
            Self::Octet => "an octet is 0 to 255".to_owned(),
            Self::Ip => "four octets, such as 192.168.15.210".to_owned(),
        }
    }
}

impl fmt::Display for Operand {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Bank => "a register bank",
            Self::Start => "the first register's address",
            Self::Count => "the number of registers",
            Self::Value => "a value",
            Self::Mask => "the effects mask",
            Self::Octet => "an octet",
            Self::Ip => "the box's new IP address",
        })
    }
}

/// What is wrong in refused console text.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Error)]
pub enum ConsoleErrorKind {
    /// A word that is no command.
    #[error(
        "unknown command `{found}`: the console knows read, write, save, estop, release, reset, effects and ip"
    )]
    UnknownCommand {
        /// The word.
        found: String,
    },
    /// A box after `@` and nothing after it.
    #[error(
        "expected a command after `{target}`: read, write, save, estop, release, reset, effects or ip"
    )]
    MissingCommand {
        /// The box, as written.
        target: String,
    },
    /// The command ends where it needs more.
    #[error("`{command}` needs {operand} here ({})", operand.range())]
    Missing {
        /// The command.
        command: &'static str,
        /// What is missing.
        operand: Operand,
    },
    /// A word where a bank should be.
    #[error("expected a register bank FN, DN or CX, found `{found}`")]
    NotABank {
        /// The word.
        found: String,
    },
    /// A bank the command cannot use.
    #[error("`{command}` does not take {bank}: {reason}")]
    WrongBank {
        /// The command.
        command: &'static str,
        /// The bank written.
        bank: &'static str,
        /// Why, and what to write instead.
        reason: &'static str,
    },
    /// A word where a number should be.
    #[error("expected {operand} as a number (decimal or 0x hex), found `{found}`")]
    NotANumber {
        /// What the number is.
        operand: Operand,
        /// The word.
        found: String,
    },
    /// A number out of its range.
    #[error("{operand} `{found}` is out of range: {}", operand.range())]
    OutOfRange {
        /// What the number is.
        operand: Operand,
        /// The number, as written.
        found: String,
    },
    /// A read of no register.
    #[error("count 0: read at least one register")]
    ZeroCount,
    /// Registers past the last address, or more than one datagram carries.
    #[error("{source}")]
    Range {
        /// What is wrong with the range.
        source: RangeError,
    },
    /// Something after a complete command.
    #[error(
        "unexpected `{found}`: `{command}` is complete without it (commands are separated by a new line or `;`)"
    )]
    Trailing {
        /// The command.
        command: &'static str,
        /// The first word too many.
        found: String,
    },
    /// Not an IP address.
    #[error("expected an IP address such as 192.168.15.210, found `{found}`")]
    NotAnIp {
        /// The word.
        found: String,
    },
    /// A target that names no box.
    #[error(
        "expected a box after `@`: all, a last octet such as 201, two octets such as 15.201 or an IP address such as 192.168.15.201, and optionally `/` and the box that replies (none: no reply); found `{found}`"
    )]
    BadTarget {
        /// The target, as written.
        found: String,
    },
    /// A last octet only, and no single selected box to take the third from.
    #[error(
        "`@{octet}` gives the last octet only, and the selected box is not one box: give two octets, such as @15.{octet}"
    )]
    NoSubnet {
        /// The octet.
        octet: u8,
    },
}

/// Reads console text: every command in it, in order, each with the route its `@box`
/// names or else `selected`. All or nothing: one mistake refuses the whole text, so
/// nothing is sent from text the operator has to correct.
///
/// # Errors
/// The first mistake, with its line and column.
pub fn parse(text: &str, selected: Route) -> Result<Vec<Operation>, ConsoleError> {
    let mut operations = Vec::new();
    for (index, line) in text.split('\n').enumerate() {
        let line_number = u32::try_from(index + 1).unwrap_or(u32::MAX);
        for words in statements(line) {
            let mut command = Command {
                words: &words,
                next: 0,
                line: line_number,
            };
            operations.push(command.operation(selected)?);
        }
    }
    Ok(operations)
}

/// A word of a command and the column of its first character.
#[derive(Debug, Clone, Copy)]
struct Word<'a> {
    text: &'a str,
    column: u32,
}

impl Word<'_> {
    /// The column just after it.
    fn end(self) -> u32 {
        let len = u32::try_from(self.text.chars().count()).unwrap_or(u32::MAX);
        self.column.saturating_add(len)
    }
}

/// The commands of one line (without its comment), each as its words; empty commands
/// are left out.
fn statements(line: &str) -> Vec<Vec<Word<'_>>> {
    let mut statements = Vec::new();
    let mut words = Vec::new();
    let mut word_start: Option<(usize, u32)> = None;
    let mut column = 0_u32;
    for (at, c) in line.char_indices() {
        column = column.saturating_add(1);
        let ends_word = c.is_whitespace() || c == ';' || c == '#';
        if ends_word {
            if let Some((start, start_column)) = word_start.take() {
                words.push(Word {
                    text: &line[start..at],
                    column: start_column,
                });
            }
        } else if word_start.is_none() {
            word_start = Some((at, column));
        }
        if (c == ';' || c == '#') && !words.is_empty() {
            statements.push(std::mem::take(&mut words));
        }
        if c == '#' {
            return statements;
        }
    }
    if let Some((start, start_column)) = word_start {
        words.push(Word {
            text: &line[start..],
            column: start_column,
        });
    }
    if !words.is_empty() {
        statements.push(words);
    }
    statements
}

/// One command's words being read.
struct Command<'w, 'a> {
    words: &'w [Word<'a>],
    next: usize,
    line: u32,
}

impl<'a> Command<'_, 'a> {
    fn error(&self, column: u32, kind: ConsoleErrorKind) -> ConsoleError {
        ConsoleError {
            line: self.line,
            column,
            kind,
        }
    }

    /// The column just after the last word.
    fn end(&self) -> u32 {
        self.words.last().map_or(1, |word| word.end())
    }

    fn next_word(&mut self) -> Option<Word<'a>> {
        let word = self.words.get(self.next).copied();
        if word.is_some() {
            self.next += 1;
        }
        word
    }

    /// The next word, or the error that `command` needs `operand`.
    fn needs(&mut self, command: &'static str, operand: Operand) -> Result<Word<'a>, ConsoleError> {
        self.next_word()
            .ok_or_else(|| self.error(self.end(), ConsoleErrorKind::Missing { command, operand }))
    }

    /// The next word as a number of at most `max`.
    fn number(
        &mut self,
        command: &'static str,
        operand: Operand,
        max: u64,
    ) -> Result<(u64, Word<'a>), ConsoleError> {
        let word = self.needs(command, operand)?;
        let value =
            number(word.text, operand, max).map_err(|kind| self.error(word.column, kind))?;
        Ok((value, word))
    }

    /// The next word as a 16-bit number.
    fn u16(&mut self, command: &'static str, operand: Operand) -> Result<u16, ConsoleError> {
        let (value, _) = self.number(command, operand, u64::from(u16::MAX))?;
        Ok(u16::try_from(value).unwrap_or(u16::MAX))
    }

    /// The whole command: an optional `@box`, the command word and its operands.
    fn operation(&mut self, selected: Route) -> Result<Operation, ConsoleError> {
        let mut route = selected;
        let mut first = self.next_word();
        if let Some(word) = first.filter(|word| word.text.starts_with('@')) {
            route = target(word.text, selected).map_err(|kind| self.error(word.column, kind))?;
            first = self.next_word();
            if first.is_none() {
                let kind = ConsoleErrorKind::MissingCommand {
                    target: word.text.to_owned(),
                };
                return Err(self.error(word.end(), kind));
            }
        }
        let Some(word) = first else {
            // `statements` leaves empty commands out.
            return Err(self.error(
                1,
                ConsoleErrorKind::MissingCommand {
                    target: String::new(),
                },
            ));
        };
        let Some(command) = COMMANDS
            .into_iter()
            .find(|name| name.eq_ignore_ascii_case(word.text))
        else {
            let kind = ConsoleErrorKind::UnknownCommand {
                found: word.text.to_owned(),
            };
            return Err(self.error(word.column, kind));
        };
        let operation = match command {
            "read" => Operation::Read(self.read(route)?),
            "write" | "save" => Operation::Write(self.write(command, route)?),
            "estop" => Operation::Write(RegisterWrite::estop(route)),
            "release" => Operation::Write(RegisterWrite::release_estop(route)),
            "reset" => Operation::Write(RegisterWrite::reset(route)),
            "effects" => Operation::Write(RegisterWrite::effects(
                route,
                self.u16(command, Operand::Mask)?,
            )),
            _ => Operation::Write(RegisterWrite::set_ip(route, self.ip()?)),
        };
        if let Some(extra) = self.next_word() {
            let kind = ConsoleErrorKind::Trailing {
                command,
                found: extra.text.to_owned(),
            };
            return Err(self.error(extra.column, kind));
        }
        Ok(operation)
    }

    /// The bank word: FN, DN or CX.
    fn bank(&mut self, command: &'static str) -> Result<(&'static str, Word<'a>), ConsoleError> {
        let word = self.needs(command, Operand::Bank)?;
        ["FN", "DN", "CX"]
            .into_iter()
            .find(|bank| bank.eq_ignore_ascii_case(word.text))
            .map(|bank| (bank, word))
            .ok_or_else(|| {
                let kind = ConsoleErrorKind::NotABank {
                    found: word.text.to_owned(),
                };
                self.error(word.column, kind)
            })
    }

    /// `read BANK START COUNT`.
    fn read(&mut self, route: Route) -> Result<RegisterRead, ConsoleError> {
        let (bank, word) = self.bank("read")?;
        let bank = match bank {
            "FN" => ReadBank::Fn,
            "DN" => ReadBank::Dn,
            _ => {
                let kind = ConsoleErrorKind::WrongBank {
                    command: "read",
                    bank,
                    reason: "CX command registers cannot be read over UDP; read FN or DN",
                };
                return Err(self.error(word.column, kind));
            }
        };
        let start = self.u16("read", Operand::Start)?;
        let max = u64::try_from(MAX_REGISTERS).unwrap_or(u64::MAX);
        let (count, word) = self.number("read", Operand::Count, max)?;
        if count == 0 {
            return Err(self.error(word.column, ConsoleErrorKind::ZeroCount));
        }
        let count = usize::try_from(count).unwrap_or(usize::MAX);
        let range = RegisterRange::new(start, count)
            .map_err(|source| self.error(word.column, ConsoleErrorKind::Range { source }))?;
        Ok(RegisterRead { bank, route, range })
    }

    /// `write BANK START VALUE…` (FN not saved, or CX) and `save FN START VALUE…`.
    fn write(
        &mut self,
        command: &'static str,
        route: Route,
    ) -> Result<RegisterWrite, ConsoleError> {
        let (bank, word) = self.bank(command)?;
        let wrong = |reason| ConsoleErrorKind::WrongBank {
            command,
            bank,
            reason,
        };
        let bank = match (command, bank) {
            ("save", "FN") => WriteBank::FnSaved,
            ("save", _) => {
                let reason = "only FN parameters are saved; write CX … for command registers";
                return Err(self.error(word.column, wrong(reason)));
            }
            (_, "FN") => WriteBank::FnVolatile,
            (_, "CX") => WriteBank::Cx,
            _ => {
                let reason = "DN parameters cannot be written; write FN or CX";
                return Err(self.error(word.column, wrong(reason)));
            }
        };
        let start = self.u16(command, Operand::Start)?;
        let mut values = vec![self.u16(command, Operand::Value)?];
        while let Some(word) = self.words.get(self.next).copied() {
            let count = values.len() + 1;
            if let Err(source) = RegisterRange::new(start, count) {
                return Err(self.error(word.column, ConsoleErrorKind::Range { source }));
            }
            values.push(self.u16(command, Operand::Value)?);
        }
        let column = word.column;
        let block = RegisterBlock::new(start, values)
            .map_err(|source| self.error(column, ConsoleErrorKind::Range { source }))?;
        Ok(RegisterWrite { bank, route, block })
    }

    /// `ip A.B.C.D`.
    fn ip(&mut self) -> Result<Ipv4Addr, ConsoleError> {
        let word = self.needs("ip", Operand::Ip)?;
        word.text.parse().map_err(|_| {
            let kind = ConsoleErrorKind::NotAnIp {
                found: word.text.to_owned(),
            };
            self.error(word.column, kind)
        })
    }
}

/// A number in decimal or `0x` hex, at most `max`.
fn number(text: &str, operand: Operand, max: u64) -> Result<u64, ConsoleErrorKind> {
    let (digits, radix) = match (text.get(..2), text.get(2..)) {
        (Some(prefix), Some(digits)) if prefix.eq_ignore_ascii_case("0x") => (digits, 16),
        _ => (text, 10),
    };
    if digits.is_empty() || !digits.chars().all(|c| c.is_digit(radix)) {
        return Err(ConsoleErrorKind::NotANumber {
            operand,
            found: text.to_owned(),
        });
    }
    u64::from_str_radix(digits, radix)
        .ok()
        .filter(|&value| value <= max)
        .ok_or_else(|| ConsoleErrorKind::OutOfRange {
            operand,
            found: text.to_owned(),
        })
}

/// The route of `@RECEIVER` or `@RECEIVER/REPLIER`.
fn target(text: &str, selected: Route) -> Result<Route, ConsoleErrorKind> {
    let bad = || ConsoleErrorKind::BadTarget {
        found: text.to_owned(),
    };
    let rest = text.strip_prefix('@').ok_or_else(bad)?;
    let (receiver, replier) = match rest.split_once('/') {
        Some((receiver, replier)) => (receiver, Some(replier)),
        None => (rest, None),
    };
    let receiver = box_address(receiver, selected)?.ok_or_else(bad)?;
    let replier = match replier {
        Some(replier) => box_address(replier, selected)?.ok_or_else(bad)?,
        None => receiver,
    };
    Ok(Route { receiver, replier })
}

/// A box: `all`, `none`, a last octet, two octets or an IP address; `None` if it is
/// none of these.
fn box_address(text: &str, selected: Route) -> Result<Option<BoxAddress>, ConsoleErrorKind> {
    if text.eq_ignore_ascii_case("all") {
        return Ok(Some(BoxAddress::ALL));
    }
    if text.eq_ignore_ascii_case("none") {
        return Ok(Some(BoxAddress::NO_REPLY));
    }
    let parts: Vec<&str> = text.split('.').collect();
    let octet = |part: &str| -> Result<Option<u8>, ConsoleErrorKind> {
        match number(part, Operand::Octet, u64::from(u8::MAX)) {
            Ok(value) => Ok(u8::try_from(value).ok()),
            Err(ConsoleErrorKind::NotANumber { .. }) => Ok(None),
            Err(error) => Err(error),
        }
    };
    Ok(match parts.as_slice() {
        [fourth] => {
            let Some(fourth) = octet(fourth)? else {
                return Ok(None);
            };
            let selected = selected.receiver;
            if selected == BoxAddress::ALL || selected == BoxAddress::NO_REPLY {
                return Err(ConsoleErrorKind::NoSubnet { octet: fourth });
            }
            let [third, _] = selected.octets();
            Some(BoxAddress::from_octets(third, fourth))
        }
        [third, fourth] => match (octet(third)?, octet(fourth)?) {
            (Some(third), Some(fourth)) => Some(BoxAddress::from_octets(third, fourth)),
            _ => None,
        },
        [_, _, _, _] => text.parse().ok().map(BoxAddress::of_ip),
        _ => None,
    })
}

/// A box in the canonical text: `all`, `none` or its two octets.
struct BoxText(BoxAddress);

impl fmt::Display for BoxText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            BoxAddress::ALL => f.write_str("all"),
            BoxAddress::NO_REPLY => f.write_str("none"),
            address => {
                let [third, fourth] = address.octets();
                write!(f, "{third}.{fourth}")
            }
        }
    }
}

/// The bank's name.
fn read_bank_name(bank: ReadBank) -> &'static str {
    match bank {
        ReadBank::Fn => "FN",
        ReadBank::Dn => "DN",
    }
}

/// The canonical text: the route always (`@15.201`, `@all`, `@all/none`), the
/// command in lower case, the bank in upper case, addresses in 4-digit hex, values
/// in decimal; a write that is one of the named operations is printed as that command
/// (`write FN 0x90 1` prints as `estop`). [`parse`] reads it back to the same
/// operation, whatever the selected box.
impl fmt::Display for Operation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let route = self.route();
        write!(f, "@{}", BoxText(route.receiver))?;
        if route.replier != route.receiver {
            write!(f, "/{}", BoxText(route.replier))?;
        }
        let write = match self {
            Self::Read(read) => {
                let bank = read_bank_name(read.bank);
                let (start, count) = (read.range.start(), read.range.count());
                return write!(f, " read {bank} 0x{start:04X} {count}");
            }
            Self::Write(write) => write,
        };
        if let Some(named) = named(write) {
            return write!(f, " {named}");
        }
        let (command, bank) = match write.bank {
            WriteBank::FnVolatile => ("write", "FN"),
            WriteBank::FnSaved => ("save", "FN"),
            WriteBank::Cx => ("write", "CX"),
        };
        write!(f, " {command} {bank} 0x{:04X}", write.block.start())?;
        for value in write.block.values() {
            write!(f, " {value}")?;
        }
        Ok(())
    }
}

/// The named command a write is, if it is exactly one.
fn named(write: &RegisterWrite) -> Option<String> {
    let route = write.route;
    let fixed = [
        (RegisterWrite::estop(route), "estop"),
        (RegisterWrite::release_estop(route), "release"),
        (RegisterWrite::reset(route), "reset"),
    ];
    if let Some((_, name)) = fixed.iter().find(|(named, _)| named == write) {
        return Some((*name).to_owned());
    }
    match (write.bank, write.block.start(), write.block.values()) {
        (WriteBank::Cx, CX_EFFECTS, &[mask]) => Some(format!("effects 0x{mask:04X}")),
        (WriteBank::FnSaved, FN_IP, &[a, b, c, d]) => {
            let octets = [a, b, c, d].map(|value| u8::try_from(value).ok());
            let [Some(a), Some(b), Some(c), Some(d)] = octets else {
                return None;
            };
            Some(format!("ip {}", Ipv4Addr::new(a, b, c, d)))
        }
        _ => None,
    }
}

/// How [`render_reply`] lays out a reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ReplyLayout {
    /// One line, the values in decimal: `FN0020..FN0023 = 192 168 15 201`
    /// (`FN0090 = 1` for one register).
    #[default]
    Line,
    /// One register a line, in decimal and hex: `FN0020 = 192 (0x00C0)`.
    Table,
}

/// A box's reply to a read, as the console shows it; registers are named as in the
/// document, bank and 4-digit hex address (`FN0020`, `DN001F`).
#[must_use]
pub fn render_reply(reply: &RegisterReply, layout: ReplyLayout) -> String {
    let bank = read_bank_name(reply.bank);
    let block = &reply.block;
    let values = block.values();
    let first = block.start();
    let mut out = String::new();
    match layout {
        ReplyLayout::Line => {
            out.push_str(&format!("{bank}{first:04X}"));
            let count = u16::try_from(values.len()).unwrap_or(u16::MAX);
            if count > 1 {
                let last = first.saturating_add(count - 1);
                out.push_str(&format!("..{bank}{last:04X}"));
            }
            out.push_str(" =");
            for value in values {
                out.push_str(&format!(" {value}"));
            }
        }
        ReplyLayout::Table => {
            for (address, value) in (first..=u16::MAX).zip(values) {
                if !out.is_empty() {
                    out.push('\n');
                }
                out.push_str(&format!("{bank}{address:04X} = {value} (0x{value:04X})"));
            }
        }
    }
    out
}

impl Coded for ConsoleError {
    fn code(&self) -> Code {
        self.kind.code()
    }

    /// The kind's parameters, and where: `line` and `column`.
    fn params(&self) -> Params {
        crate::codes::located(&self.kind, self.line, self.column)
    }
}

impl Coded for ConsoleErrorKind {
    fn code(&self) -> Code {
        match self {
            Self::UnknownCommand { .. } => Code::MboxUnknownCommand,
            Self::MissingCommand { .. } => Code::MboxMissingCommand,
            Self::Missing { .. } => Code::MboxMissing,
            Self::NotABank { .. } => Code::MboxNotABank,
            Self::WrongBank { .. } => Code::MboxWrongBank,
            Self::NotANumber { .. } => Code::MboxNotANumber,
            Self::OutOfRange { .. } => Code::MboxOutOfRange,
            Self::ZeroCount => Code::MboxZeroCount,
            Self::Range { .. } => Code::MboxRange,
            Self::Trailing { .. } => Code::MboxTrailing,
            Self::NotAnIp { .. } => Code::MboxNotAnIp,
            Self::BadTarget { .. } => Code::MboxBadTarget,
            Self::NoSubnet { .. } => Code::MboxNoSubnet,
        }
    }

    fn params(&self) -> Params {
        match self {
            Self::UnknownCommand { found }
            | Self::NotABank { found }
            | Self::NotAnIp { found }
            | Self::BadTarget { found } => params! {"found" => found},
            Self::MissingCommand { target } => params! {"target" => target},
            Self::Missing { command, operand } => {
                params! {"command" => command, "operand" => operand}
            }
            Self::WrongBank {
                command,
                bank,
                reason,
            } => params! {"command" => command, "bank" => bank, "reason" => reason},
            Self::NotANumber { operand, found } | Self::OutOfRange { operand, found } => {
                params! {"operand" => operand, "found" => found}
            }
            Self::ZeroCount => Params::new(),
            Self::Range { source } => params! {"reason" => source},
            Self::Trailing { command, found } => params! {"command" => command, "found" => found},
            Self::NoSubnet { octet } => params! {"octet" => octet},
        }
    }
}

#[cfg(test)]
mod tests;
