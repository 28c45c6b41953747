//! The Telnet side of an `rfc2217://` link, sans IO: IAC escaping both ways, option
//! negotiation, and the COM-Port-Control option of RFC 2217 (option 44).
//!
//! No maintained crate fits a blocking, split `TcpStream` with RFC 2217 as a *client*
//! (`telnet` owns its stream and knows nothing of COM-port control; `rfc2217-rs` is a
//! server), so this is the small part written by hand:
//!
//! - [`escape`]: data going out, every 0xFF (IAC) doubled (RFC 854);
//! - [`Decoder`]: bytes coming in split into the line's data (IAC IAC → 0xFF: feedback
//!   frames are binary) and Telnet [`Event`]s (WILL/WONT/DO/DONT, subnegotiations);
//! - [`Options`]: the answers to the server's option requests — BINARY (0) and
//!   SUPPRESS-GO-AHEAD (3) accepted, COM-PORT-OPTION (44) offered by us, everything else
//!   refused with DONT/WONT — without answering an acknowledgement (no loops, RFC 1143);
//! - [`set_baud`], [`set_datasize`], [`set_parity`], [`set_stopsize`], [`set_control`]:
//!   the client's COM-port subnegotiations; [`ComPortReply`]: the server's answer (the
//!   command's code + 100 and the value it set), from which a refusal is told.

/// Interpret As Command.
pub const IAC: u8 = 255;
/// Refuses an option (the receiver must not use it).
pub const DONT: u8 = 254;
/// Asks the other end to use an option.
pub const DO: u8 = 253;
/// Refuses to use an option.
pub const WONT: u8 = 252;
/// Offers to use an option.
pub const WILL: u8 = 251;
/// Subnegotiation begins.
pub const SB: u8 = 250;
/// Subnegotiation ends.
pub const SE: u8 = 240;

/// TRANSMIT-BINARY (RFC 856): 8-bit data, no CR/NUL rules.
pub const OPT_BINARY: u8 = 0;
/// SUPPRESS-GO-AHEAD (RFC 858).
pub const OPT_SGA: u8 = 3;
/// COM-PORT-OPTION (RFC 2217).
pub const COM_PORT_OPTION: u8 = 44;

/// SET-BAUDRATE: four bytes, network order.
pub const SET_BAUDRATE: u8 = 1;
/// SET-DATASIZE: one byte (8).
pub const SET_DATASIZE: u8 = 2;
/// SET-PARITY: one byte (1 = NONE).
pub const SET_PARITY: u8 = 3;
/// SET-STOPSIZE: one byte (1 = one stop bit).
pub const SET_STOPSIZE: u8 = 4;
/// SET-CONTROL: one byte (1 = no flow control).
pub const SET_CONTROL: u8 = 5;
/// The server answers a client command with the command's code plus this.
pub const SERVER_OFFSET: u8 = 100;

/// `SET-PARITY` value for no parity.
pub const PARITY_NONE: u8 = 1;
/// `SET-STOPSIZE` value for one stop bit.
pub const STOPSIZE_ONE: u8 = 1;
/// `SET-CONTROL` value for no flow control.
pub const CONTROL_NONE: u8 = 1;

/// The longest subnegotiation kept; the rest of a longer one is dropped.
const MAX_SUBNEGOTIATION: usize = 64;

/// Appends `data` to `out` with every IAC doubled.
pub fn escape(data: &[u8], out: &mut Vec<u8>) {
    for &byte in data {
        out.push(byte);
        if byte == IAC {
            out.push(IAC);
        }
    }
}

/// `IAC <verb> <option>`.
pub fn negotiation(verb: u8, option: u8) -> [u8; 3] {
    [IAC, verb, option]
}

/// `IAC SB COM-PORT-OPTION <command> <value, escaped> IAC SE`.
fn com_port(command: u8, value: &[u8]) -> Vec<u8> {
    let mut out = vec![IAC, SB, COM_PORT_OPTION, command];
    escape(value, &mut out);
    out.extend_from_slice(&[IAC, SE]);
    out
}

/// SET-BAUDRATE `baud`.
pub fn set_baud(baud: u32) -> Vec<u8> {
    com_port(SET_BAUDRATE, &baud.to_be_bytes())
}

/// SET-DATASIZE `bits`.
pub fn set_datasize(bits: u8) -> Vec<u8> {
    com_port(SET_DATASIZE, &[bits])
}

/// SET-PARITY `parity` (1 none, 2 odd, 3 even, …).
pub fn set_parity(parity: u8) -> Vec<u8> {
    com_port(SET_PARITY, &[parity])
}

/// SET-STOPSIZE `stop` (1 one, 2 two, 3 one and a half).
pub fn set_stopsize(stop: u8) -> Vec<u8> {
    com_port(SET_STOPSIZE, &[stop])
}

/// SET-CONTROL `control` (1 no flow control, …).
pub fn set_control(control: u8) -> Vec<u8> {
    com_port(SET_CONTROL, &[control])
}

/// What the decoder found besides data.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Event {
    /// `IAC WILL option`.
    Will(u8),
    /// `IAC WONT option`.
    Wont(u8),
    /// `IAC DO option`.
    Do(u8),
    /// `IAC DONT option`.
    Dont(u8),
    /// `IAC SB option payload IAC SE`, the payload unescaped.
    Sub(u8, Vec<u8>),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Data,
    Iac,
    Verb(u8),
    SubOption,
    Sub,
    SubIac,
}

/// Splits a Telnet byte stream into data and [`Event`]s; keeps its state across
/// reads (a sequence may be cut anywhere).
#[derive(Debug, Clone)]
pub struct Decoder {
    state: State,
    option: u8,
    payload: Vec<u8>,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// A decoder at the start of a stream.
    pub fn new() -> Self {
        Self {
            state: State::Data,
            option: 0,
            payload: Vec::new(),
        }
    }

    /// Decodes `input`: the line's data is appended to `data`, the Telnet events to
    /// `events`. Commands without an option (NOP, GA, AYT, …) are dropped.
    pub fn push(&mut self, input: &[u8], data: &mut Vec<u8>, events: &mut Vec<Event>) {
        for &byte in input {
            self.state = match self.state {
                State::Data if byte == IAC => State::Iac,
                State::Data => {
                    data.push(byte);
                    State::Data
                }
                State::Iac => match byte {
                    IAC => {
                        data.push(IAC);
                        State::Data
                    }
                    WILL | WONT | DO | DONT => State::Verb(byte),
                    SB => State::SubOption,
                    _ => State::Data,
                },
                State::Verb(verb) => {
                    events.push(match verb {
                        WILL => Event::Will(byte),
                        WONT => Event::Wont(byte),
                        DO => Event::Do(byte),
                        _ => Event::Dont(byte),
                    });
                    State::Data
                }
                State::SubOption => {
                    self.option = byte;
                    self.payload.clear();
                    State::Sub
                }
                State::Sub if byte == IAC => State::SubIac,
                State::Sub => {
                    self.keep(byte);
                    State::Sub
                }
                State::SubIac => match byte {
                    IAC => {
                        self.keep(IAC);
                        State::Sub
                    }
                    SE => {
                        events.push(Event::Sub(self.option, std::mem::take(&mut self.payload)));
                        State::Data
                    }
                    // Not allowed inside a subnegotiation: end it there.
                    _ => State::Data,
                },
            };
        }
    }

    fn keep(&mut self, byte: u8) {
        if self.payload.len() < MAX_SUBNEGOTIATION {
            self.payload.push(byte);
        }
    }
}

/// One end's view of an option (RFC 1143, without the queue).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
enum Side {
    #[default]
    No,
    /// We asked and wait for the answer.
    WantYes,
    Yes,
}

/// What became of our offer of COM-port control.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ComPortAgreement {
    /// The server said DO COM-PORT-OPTION.
    Agreed,
    /// The server said DONT COM-PORT-OPTION.
    Refused,
}

/// The server's answer to one of our COM-port commands.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ComPortReply {
    /// The client command it answers (1 SET-BAUDRATE … 5 SET-CONTROL, …).
    pub command: u8,
    /// The value the server set (or has, when it did not set ours).
    pub value: Vec<u8>,
}

impl ComPortReply {
    /// The value as a baud rate (SET-BAUDRATE's four bytes), if it is one.
    pub fn baud(&self) -> Option<u32> {
        <[u8; 4]>::try_from(self.value.as_slice())
            .ok()
            .map(u32::from_be_bytes)
    }
}

/// What handling an event produced.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Handled {
    /// Bytes to send back (negotiation answers).
    pub reply: Vec<u8>,
    /// The answer to our COM-PORT-OPTION offer, when this event was it.
    pub agreement: Option<ComPortAgreement>,
    /// A server answer to a COM-port command.
    pub com_port: Option<ComPortReply>,
}

/// The client's options: what we use (`local`) and what the server uses (`remote`).
#[derive(Debug, Clone)]
pub struct Options {
    local: [Side; 256],
    remote: [Side; 256],
}

impl Default for Options {
    fn default() -> Self {
        Self::new()
    }
}

impl Options {
    /// No option in use yet.
    pub fn new() -> Self {
        Self {
            local: [Side::No; 256],
            remote: [Side::No; 256],
        }
    }

    /// What the client sends first: WILL COM-PORT-OPTION, and binary both ways (the
    /// feedback is binary; a server not in binary mode may add NULs after CR).
    pub fn start(&mut self) -> Vec<u8> {
        self.local[usize::from(COM_PORT_OPTION)] = Side::WantYes;
        self.local[usize::from(OPT_BINARY)] = Side::WantYes;
        self.remote[usize::from(OPT_BINARY)] = Side::WantYes;
        [
            negotiation(WILL, COM_PORT_OPTION),
            negotiation(WILL, OPT_BINARY),
            negotiation(DO, OPT_BINARY),
        ]
        .concat()
    }

    /// Options we use when the server asks.
    fn accept_local(option: u8) -> bool {
        matches!(option, OPT_BINARY | OPT_SGA | COM_PORT_OPTION)
    }

    /// Options we let the server use.
    fn accept_remote(option: u8) -> bool {
        matches!(option, OPT_BINARY | OPT_SGA)
    }

    /// Answers one event.
    pub fn handle(&mut self, event: Event) -> Handled {
        let mut handled = Handled::default();
        match event {
            Event::Do(option) => {
                let side = &mut self.local[usize::from(option)];
                match *side {
                    Side::Yes => {}
                    Side::WantYes => *side = Side::Yes,
                    Side::No if Self::accept_local(option) => {
                        *side = Side::Yes;
                        handled.reply.extend(negotiation(WILL, option));
                    }
                    Side::No => handled.reply.extend(negotiation(WONT, option)),
                }
                if option == COM_PORT_OPTION {
                    handled.agreement = Some(ComPortAgreement::Agreed);
                }
            }
            Event::Dont(option) => {
                let side = &mut self.local[usize::from(option)];
                match *side {
                    Side::No => {}
                    Side::WantYes => *side = Side::No,
                    Side::Yes => {
                        *side = Side::No;
                        handled.reply.extend(negotiation(WONT, option));
                    }
                }
                if option == COM_PORT_OPTION {
                    handled.agreement = Some(ComPortAgreement::Refused);
                }
            }
            Event::Will(option) => {
                let side = &mut self.remote[usize::from(option)];
                match *side {
                    Side::Yes => {}
                    Side::WantYes => *side = Side::Yes,
                    Side::No if Self::accept_remote(option) => {
                        *side = Side::Yes;
                        handled.reply.extend(negotiation(DO, option));
                    }
                    Side::No => handled.reply.extend(negotiation(DONT, option)),
                }
            }
            Event::Wont(option) => {
                let side = &mut self.remote[usize::from(option)];
                match *side {
                    Side::No => {}
                    Side::WantYes => *side = Side::No,
                    Side::Yes => {
                        *side = Side::No;
                        handled.reply.extend(negotiation(DONT, option));
                    }
                }
            }
            Event::Sub(COM_PORT_OPTION, payload) => {
                if let Some((&code, value)) = payload.split_first()
                    && code > SERVER_OFFSET
                {
                    handled.com_port = Some(ComPortReply {
                        command: code - SERVER_OFFSET,
                        value: value.to_vec(),
                    });
                }
            }
            Event::Sub(..) => {}
        }
        handled
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode(input: &[u8]) -> (Vec<u8>, Vec<Event>) {
        let mut data = Vec::new();
        let mut events = Vec::new();
        Decoder::new().push(input, &mut data, &mut events);
        (data, events)
    }

    #[test]
    fn iac_is_doubled_out_and_undoubled_in() {
        let mut out = Vec::new();
        escape(b"\x01\xff\x02\xff\xff", &mut out);
        assert_eq!(out, b"\x01\xff\xff\x02\xff\xff\xff\xff");
        let (data, events) = decode(&out);
        assert_eq!(data, b"\x01\xff\x02\xff\xff");
        assert!(events.is_empty());
    }

    #[test]
    fn sequences_cut_anywhere_decode_the_same() {
        // Data, IAC IAC, a negotiation and a COM-port answer, fed one byte at a time.
        let stream = [
            b'A', IAC, IAC, b'B', IAC, DO, 44, IAC, SB, 44, 101, 0, 1, 0xC2, 0, IAC, SE, b'C',
        ];
        let mut decoder = Decoder::new();
        let mut data = Vec::new();
        let mut events = Vec::new();
        for byte in stream {
            decoder.push(&[byte], &mut data, &mut events);
        }
        assert_eq!(data, b"A\xffBC");
        assert_eq!(
            events,
            [Event::Do(44), Event::Sub(44, vec![101, 0, 1, 0xC2, 0])]
        );
    }

    #[test]
    fn commands_without_an_option_are_dropped() {
        // NOP (241), GA (249).
        let (data, events) = decode(&[b'x', IAC, 241, b'y', IAC, 249]);
        assert_eq!(data, b"xy");
        assert!(events.is_empty());
    }

    #[test]
    fn a_doubled_iac_inside_a_subnegotiation_is_one_value_byte() {
        // SET-BAUDRATE answer of 0x0000FFFF baud: the 0xFF bytes are doubled on the wire.
        let (_, events) = decode(&[IAC, SB, 44, 101, 0, 0, IAC, IAC, IAC, IAC, IAC, SE]);
        let Some(Event::Sub(44, payload)) = events.first() else {
            panic!("{events:?}");
        };
        let reply = Options::new().handle(Event::Sub(44, payload.clone()));
        assert_eq!(reply.com_port.and_then(|r| r.baud()), Some(0xFFFF));
    }

    #[test]
    fn com_port_commands_are_the_rfc_byte_sequences() {
        // RFC 2217: IAC SB COM-PORT-OPTION SET-BAUDRATE <value(4)> IAC SE, network order.
        assert_eq!(
            set_baud(115_200),
            [IAC, SB, 44, 1, 0x00, 0x01, 0xC2, 0x00, IAC, SE]
        );
        assert_eq!(
            set_baud(9600),
            [255, 250, 44, 1, 0, 0, 0x25, 0x80, 255, 240]
        );
        assert_eq!(set_datasize(8), [255, 250, 44, 2, 8, 255, 240]);
        assert_eq!(set_parity(PARITY_NONE), [255, 250, 44, 3, 1, 255, 240]);
        assert_eq!(set_stopsize(STOPSIZE_ONE), [255, 250, 44, 4, 1, 255, 240]);
        assert_eq!(set_control(CONTROL_NONE), [255, 250, 44, 5, 1, 255, 240]);
        // A value holding 0xFF is escaped inside the subnegotiation too.
        assert_eq!(
            set_baud(0x00FF_0000),
            [IAC, SB, 44, 1, 0, IAC, IAC, 0, 0, IAC, SE]
        );
    }

    #[test]
    fn the_client_offers_com_port_control_and_takes_the_answer_without_echoing_it() {
        let mut options = Options::new();
        assert_eq!(options.start(), [IAC, WILL, 44, IAC, WILL, 0, IAC, DO, 0]);
        // The server agrees: no answer to an acknowledgement.
        let handled = options.handle(Event::Do(44));
        assert_eq!(handled.agreement, Some(ComPortAgreement::Agreed));
        assert!(handled.reply.is_empty());
        assert!(options.handle(Event::Do(44)).reply.is_empty());
        assert!(options.handle(Event::Will(OPT_BINARY)).reply.is_empty());
        assert!(options.handle(Event::Do(OPT_BINARY)).reply.is_empty());
        // Later withdrawn: acknowledged once.
        let handled = options.handle(Event::Dont(44));
        assert_eq!(handled.agreement, Some(ComPortAgreement::Refused));
        assert_eq!(handled.reply, [IAC, WONT, 44]);
        assert!(options.handle(Event::Dont(44)).reply.is_empty());
    }

    #[test]
    fn a_refusal_of_our_offer_is_not_answered() {
        let mut options = Options::new();
        options.start();
        let handled = options.handle(Event::Dont(44));
        assert_eq!(handled.agreement, Some(ComPortAgreement::Refused));
        assert!(handled.reply.is_empty());
    }

    #[test]
    fn other_options_are_refused_and_sga_accepted() {
        let mut options = Options::new();
        // ser2net's opening: WILL SGA, WILL ECHO, DONT ECHO, DO COM-PORT.
        assert_eq!(options.handle(Event::Will(OPT_SGA)).reply, [IAC, DO, 3]);
        assert_eq!(options.handle(Event::Will(1)).reply, [IAC, DONT, 1]);
        assert!(options.handle(Event::Dont(1)).reply.is_empty());
        assert_eq!(options.handle(Event::Do(44)).reply, [IAC, WILL, 44]);
        // Terminal type (24), NAWS (31): we will not.
        assert_eq!(options.handle(Event::Do(24)).reply, [IAC, WONT, 24]);
        assert_eq!(options.handle(Event::Do(31)).reply, [IAC, WONT, 31]);
        assert!(options.handle(Event::Wont(24)).reply.is_empty());
    }

    #[test]
    fn server_answers_are_code_plus_100() {
        let mut options = Options::new();
        let reply = options
            .handle(Event::Sub(44, vec![101, 0, 0, 0x25, 0x80]))
            .com_port;
        assert_eq!(
            reply,
            Some(ComPortReply {
                command: SET_BAUDRATE,
                value: vec![0, 0, 0x25, 0x80]
            })
        );
        assert_eq!(reply.and_then(|r| r.baud()), Some(9600));
        let reply = options.handle(Event::Sub(44, vec![102, 8])).com_port;
        assert_eq!(reply.map(|r| (r.command, r.value)), Some((2, vec![8])));
        // The server's signature (100) and client-side codes are not answers.
        assert_eq!(options.handle(Event::Sub(44, vec![100])).com_port, None);
        assert_eq!(options.handle(Event::Sub(44, vec![1, 0])).com_port, None);
        assert_eq!(options.handle(Event::Sub(44, vec![])).com_port, None);
        assert_eq!(options.handle(Event::Sub(24, vec![1])).com_port, None);
    }
}
