//! Art-Net 4's receive side, sans-IO: [`decode`] reads one UDP datagram (port 6454)
//! into an [`ArtDmx`] (DMX data for one universe), an [`ArtPoll`] (a console looking
//! for nodes) or [`Packet::Other`] (a valid Art-Net header with an OpCode a receiver of
//! DMX has no use for: ArtSync, ArtPollReply of other nodes, ArtAddress...), and
//! [`PollReply::encode`] builds the `ArtPollReply` that makes consoles discover the
//! bridge as a node whose output ports take DMX from Art-Net.
//!
//! Layouts (Art-Net 4, Artistic Licence): every packet starts with the ID
//! `"Art-Net\0"` and a little-endian OpCode; the protocol version (14) is big-endian.
//!
//! | packet | bytes |
//! |---|---|
//! | `ArtDmx` (0x5000) | ID 0–7, OpCode 8–9, ProtVer 10–11, Sequence 12, Physical 13, SubUni 14, Net 15, Length 16–17 (big-endian, even, 2–512), data 18… |
//! | `ArtPoll` (0x2000) | ID, OpCode, ProtVer, Flags 12, DiagPriority 13, then (Art-Net 4) target Port-Addresses, ESTA, OEM; consumers accept 12 bytes or more, missing fields read as zero |
//! | `ArtPollReply` (0x2100) | 239 bytes: IP 10–13, port 0x1936 (little-endian) 14–15, version 16–17, NetSwitch 18, SubSwitch 19, OEM 20–21, UBEA 22, Status1 23, ESTA 24–25 (little-endian), short name 26–43, long name 44–107, node report 108–171, NumPorts 172–173, PortTypes 174–177, GoodInput 178–181, GoodOutputA 182–185, SwIn 186–189, SwOut 190–193, AcnPriority 194, SwMacro 195, SwRemote 196, spare 197–199, Style 200, MAC 201–206, BindIp 207–210, BindIndex 211, Status2 212, GoodOutputB 213–216, Status3 217, default responder 218–223, user 224–225, refresh rate 226–227, filler 228–238 |
//!
//! A universe's 15-bit Port-Address is Net (7 bits) : Sub-Net (4 bits) : Universe (4
//! bits); `ArtDmx` carries the low byte (Sub-Net and Universe) in SubUni and the Net in
//! Net. Floatball numbers universes from 1 as consoles show them ("universe 1" =
//! Port-Address 0:0:0, [`PortAddress::universe`]), the same numbers as sACN's.
//!
//! Written by hand rather than with a crate: the whole receive side is three fixed
//! layouts; the crates that exist (`artnet_protocol`) bring dependencies into the
//! shared lock file for what is a hundred lines here, and do not give the typed,
//! never-panicking refusals the bridge counts. Every malformation is an
//! [`ArtNetError`]; nothing here panics on any input (the fuzz target
//! `artnet` feeds it noise).

use thiserror::Error;

/// The UDP port of Art-Net.
pub const PORT: u16 = 0x1936;

/// The ID every Art-Net packet starts with.
pub const ID: [u8; 8] = *b"Art-Net\0";

/// OpCode of `ArtPoll`.
pub const OP_POLL: u16 = 0x2000;
/// OpCode of `ArtPollReply`.
pub const OP_POLL_REPLY: u16 = 0x2100;
/// OpCode of `ArtDmx` (OpOutput).
pub const OP_DMX: u16 = 0x5000;

/// The lowest protocol version a receiver accepts (and the one it sends).
pub const PROTOCOL_VERSION: u16 = 14;

/// Length of an `ArtDmx` header (data starts here).
pub const DMX_HEADER_LEN: usize = 18;

/// The shortest `ArtPoll` consumers accept (Art-Net 4: "12 octets or larger").
pub const POLL_MIN_LEN: usize = 12;

/// Length of the `ArtPollReply` this module builds.
pub const POLL_REPLY_LEN: usize = 239;

/// Most DMX slots in a universe.
pub const MAX_SLOTS: usize = 512;

/// A 15-bit Art-Net Port-Address (0..=32767): Net, Sub-Net and Universe.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PortAddress(u16);

impl PortAddress {
    /// The Port-Address `net:sub_net:universe` (7, 4 and 4 bits), if each is in range.
    #[must_use]
    pub fn new(net: u8, sub_net: u8, universe: u8) -> Option<Self> {
        (net < 128 && sub_net < 16 && universe < 16)
            .then(|| Self((u16::from(net) << 8) | (u16::from(sub_net) << 4) | u16::from(universe)))
    }

    /// The Port-Address of its 15-bit number.
    #[must_use]
    pub fn from_raw(raw: u16) -> Option<Self> {
        (raw < 0x8000).then_some(Self(raw))
    }

    /// The Port-Address of a Floatball universe (1..=32768; "universe 1" = 0:0:0).
    #[must_use]
    pub fn of_universe(universe: u16) -> Option<Self> {
        universe.checked_sub(1).and_then(Self::from_raw)
    }

    /// Its 15-bit number.
    #[must_use]
    pub const fn raw(self) -> u16 {
        self.0
    }

    /// Net (bits 14–8).
    #[must_use]
    pub const fn net(self) -> u8 {
        (self.0 >> 8) as u8
    }

    /// Sub-Net (bits 7–4).
    #[must_use]
    pub const fn sub_net(self) -> u8 {
        ((self.0 >> 4) & 0xf) as u8
    }

    /// Universe within the Sub-Net (bits 3–0).
    #[must_use]
    pub const fn universe_low(self) -> u8 {
        (self.0 & 0xf) as u8
    }

    /// The Floatball universe number (1-based, as consoles show it): raw + 1.
    #[must_use]
    pub const fn universe(self) -> u16 {
        self.0 + 1
    }
}

/// An `ArtDmx` packet: DMX data for one universe.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ArtDmx<'a> {
    /// The sequence number (0 = the sender does not sequence).
    pub sequence: u8,
    /// The physical input port the data came from (informative).
    pub physical: u8,
    /// Where the data goes.
    pub port_address: PortAddress,
    /// The DMX slots (2..=512, an even number), start code excluded.
    pub data: &'a [u8],
}

/// An `ArtPoll` packet: a controller asking who is there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArtPoll {
    /// The flags (bit 1: send `ArtPollReply` on change; bit 5: targeted mode...).
    pub flags: u8,
    /// The lowest priority of diagnostics the controller wants.
    pub diag_priority: u8,
}

/// One decoded Art-Net datagram.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Packet<'a> {
    /// DMX data.
    Dmx(ArtDmx<'a>),
    /// A poll: answer with [`PollReply::encode`].
    Poll(ArtPoll),
    /// A well-formed header with another OpCode, ignored by a DMX receiver.
    Other {
        /// Its OpCode.
        op_code: u16,
    },
}

/// Why a datagram is not an Art-Net packet this receiver can use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum ArtNetError {
    /// Shorter than its header or than its length field says.
    #[error("truncated: {len} bytes, at least {needed} needed")]
    Truncated {
        /// Bytes received.
        len: usize,
        /// Bytes needed.
        needed: usize,
    },
    /// Does not start with `"Art-Net\0"`.
    #[error("not Art-Net (no \"Art-Net\\0\" ID)")]
    BadId,
    /// A protocol version below 14.
    #[error("protocol version {version}, at least 14 expected")]
    OldVersion {
        /// The version found.
        version: u16,
    },
    /// An `ArtDmx` length that is odd, 0 or above 512.
    #[error("DMX length {length}: an even number from 2 to 512 expected")]
    BadLength {
        /// The length field.
        length: u16,
    },
    /// The Net field of an `ArtDmx` has its top bit set (Port-Addresses are 15 bits).
    #[error("Net {net} out of range (0-127)")]
    BadNet {
        /// The Net field.
        net: u8,
    },
}

/// Reads one datagram.
///
/// # Errors
/// [`ArtNetError`] for anything that is not a usable Art-Net packet.
pub fn decode(datagram: &[u8]) -> Result<Packet<'_>, ArtNetError> {
    if datagram.len() < ID.len() + 2 {
        if datagram.len() >= ID.len() && datagram[..ID.len()] != ID {
            return Err(ArtNetError::BadId);
        }
        return Err(ArtNetError::Truncated {
            len: datagram.len(),
            needed: ID.len() + 4,
        });
    }
    if datagram[..ID.len()] != ID {
        return Err(ArtNetError::BadId);
    }
    let op_code = u16::from_le_bytes([datagram[8], datagram[9]]);
    if op_code != OP_DMX && op_code != OP_POLL {
        return Ok(Packet::Other { op_code });
    }
    let Some(&[hi, lo]) = datagram.get(10..12) else {
        return Err(ArtNetError::Truncated {
            len: datagram.len(),
            needed: 12,
        });
    };
    let version = u16::from_be_bytes([hi, lo]);
    if version < PROTOCOL_VERSION {
        return Err(ArtNetError::OldVersion { version });
    }
    if op_code == OP_POLL {
        // POLL_MIN_LEN is 12: already there.
        return Ok(Packet::Poll(ArtPoll {
            flags: datagram.get(12).copied().unwrap_or(0),
            diag_priority: datagram.get(13).copied().unwrap_or(0),
        }));
    }
    let Some(header) = datagram.get(..DMX_HEADER_LEN) else {
        return Err(ArtNetError::Truncated {
            len: datagram.len(),
            needed: DMX_HEADER_LEN,
        });
    };
    let (sequence, physical, sub_uni, net) = (header[12], header[13], header[14], header[15]);
    let length = u16::from_be_bytes([header[16], header[17]]);
    if length < 2 || length > MAX_SLOTS as u16 || length % 2 != 0 {
        return Err(ArtNetError::BadLength { length });
    }
    if net >= 0x80 {
        return Err(ArtNetError::BadNet { net });
    }
    let needed = DMX_HEADER_LEN + usize::from(length);
    let Some(data) = datagram.get(DMX_HEADER_LEN..needed) else {
        return Err(ArtNetError::Truncated {
            len: datagram.len(),
            needed,
        });
    };
    Ok(Packet::Dmx(ArtDmx {
        sequence,
        physical,
        port_address: PortAddress((u16::from(net) << 8) | u16::from(sub_uni)),
        data,
    }))
}

/// Encodes an `ArtDmx` (for tests, fuzzing and a simulated console): `data` is cut to
/// 512 slots and padded to an even length of at least 2.
#[must_use]
pub fn encode_dmx(sequence: u8, port_address: PortAddress, data: &[u8]) -> Vec<u8> {
    let data = &data[..data.len().min(MAX_SLOTS)];
    let length = data.len().max(2).next_multiple_of(2);
    let mut out = Vec::with_capacity(DMX_HEADER_LEN + length);
    out.extend_from_slice(&ID);
    out.extend_from_slice(&OP_DMX.to_le_bytes());
    out.extend_from_slice(&PROTOCOL_VERSION.to_be_bytes());
    out.extend_from_slice(&[
        sequence,
        0,
        (port_address.0 & 0xff) as u8,
        port_address.net(),
    ]);
    out.extend_from_slice(&(length as u16).to_be_bytes());
    out.extend_from_slice(data);
    out.resize(DMX_HEADER_LEN + length, 0);
    out
}

/// Encodes an `ArtPoll` (14 bytes: flags and diagnostics priority).
#[must_use]
pub fn encode_poll(poll: ArtPoll) -> Vec<u8> {
    let mut out = Vec::with_capacity(14);
    out.extend_from_slice(&ID);
    out.extend_from_slice(&OP_POLL.to_le_bytes());
    out.extend_from_slice(&PROTOCOL_VERSION.to_be_bytes());
    out.extend_from_slice(&[poll.flags, poll.diag_priority]);
    out
}

/// What the bridge tells consoles about itself in its `ArtPollReply`. One reply
/// describes up to four output ports sharing Net and Sub-Net; a node with more
/// universes sends one reply per group of four (`bind_index` 1, 2...), as Art-Net 4's
/// binding asks ([`PollReply::for_universes`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PollReply {
    /// The node's IPv4 address.
    pub ip: [u8; 4],
    /// Firmware version.
    pub version: u16,
    /// Net switch (bits 14–8 of the ports' Port-Addresses).
    pub net: u8,
    /// Sub-Net switch (bits 7–4).
    pub sub_net: u8,
    /// OEM code (0x00ff: "unknown / not registered").
    pub oem: u16,
    /// ESTA manufacturer code (0x7ff0..: prototyping range).
    pub esta: u16,
    /// Short name (at most 17 bytes sent).
    pub short_name: String,
    /// Long name (at most 63 bytes sent).
    pub long_name: String,
    /// The node report (at most 63 bytes sent), e.g. `#0001 [0042] Power On Tests successful`.
    pub node_report: String,
    /// Universe (bits 3–0) of each output port; 1 to 4 ports.
    pub outputs: Vec<u8>,
    /// Which output ports have received data (GoodOutputA bit 7).
    pub receiving: [bool; 4],
    /// MAC address (zeros when unknown).
    pub mac: [u8; 6],
    /// The root node's IP when several replies describe one bridge.
    pub bind_ip: [u8; 4],
    /// This reply's place among them (1 = the root).
    pub bind_index: u8,
}

/// OEM code for "unknown / not registered" (Art-Net's OemUnknown).
pub const OEM_UNKNOWN: u16 = 0x00ff;

/// An ESTA manufacturer code in the range ESTA reserves for prototypes.
pub const ESTA_PROTOTYPE: u16 = 0x7ff0;

/// Status1: indicators normal (bits 7–6 = 11), Port-Address set from the network or
/// configuration (bits 5–4 = 10).
const STATUS1: u8 = 0b1110_0000;

/// Status2: 15-bit Port-Addresses (bit 3), web configuration (bit 0).
const STATUS2: u8 = 0b0000_1001;

/// PortTypes: the port outputs data from Art-Net (bit 7), protocol DMX512 (0).
const PORT_OUTPUT_DMX: u8 = 0x80;

/// Style: StNode, a DMX to / from Art-Net device.
const STYLE_NODE: u8 = 0x00;

impl PollReply {
    /// The replies describing a node whose output ports take `universes` (Floatball's
    /// numbering, each 1..=32768): the universes grouped by Net and Sub-Net, four per
    /// reply, `bind_index` counting from 1; `template` gives the rest of each reply.
    /// Universes outside Art-Net's range are left out.
    #[must_use]
    pub fn for_universes(template: &Self, universes: &[u16]) -> Vec<Self> {
        let mut addresses: Vec<PortAddress> = universes
            .iter()
            .filter_map(|&universe| PortAddress::of_universe(universe))
            .collect();
        addresses.sort_unstable();
        addresses.dedup();
        let mut replies: Vec<Self> = Vec::new();
        for address in addresses {
            let group = address.raw() >> 4;
            match replies.last_mut() {
                Some(reply)
                    if (u16::from(reply.net) << 4 | u16::from(reply.sub_net)) == group
                        && reply.outputs.len() < 4 =>
                {
                    reply.outputs.push(address.universe_low());
                }
                _ => {
                    let mut reply = template.clone();
                    reply.net = address.net();
                    reply.sub_net = address.sub_net();
                    reply.outputs = vec![address.universe_low()];
                    reply.bind_ip = template.ip;
                    reply.bind_index = u8::try_from(replies.len() + 1).unwrap_or(u8::MAX);
                    replies.push(reply);
                }
            }
        }
        if replies.is_empty() {
            // No universe patched: the node still answers, with no ports.
            let mut reply = template.clone();
            reply.outputs.clear();
            reply.bind_ip = template.ip;
            reply.bind_index = 1;
            replies.push(reply);
        }
        replies
    }

    /// The 239-byte `ArtPollReply`.
    #[must_use]
    pub fn encode(&self) -> [u8; POLL_REPLY_LEN] {
        let mut out = [0u8; POLL_REPLY_LEN];
        out[..8].copy_from_slice(&ID);
        out[8..10].copy_from_slice(&OP_POLL_REPLY.to_le_bytes());
        out[10..14].copy_from_slice(&self.ip);
        out[14..16].copy_from_slice(&PORT.to_le_bytes());
        out[16..18].copy_from_slice(&self.version.to_be_bytes());
        out[18] = self.net & 0x7f;
        out[19] = self.sub_net & 0x0f;
        out[20..22].copy_from_slice(&self.oem.to_be_bytes());
        out[22] = 0; // UBEA version: none.
        out[23] = STATUS1;
        out[24..26].copy_from_slice(&self.esta.to_le_bytes());
        put_text(&mut out[26..44], &self.short_name);
        put_text(&mut out[44..108], &self.long_name);
        put_text(&mut out[108..172], &self.node_report);
        let ports = self.outputs.len().min(4);
        out[172..174].copy_from_slice(&(ports as u16).to_be_bytes());
        for (port, &universe) in self.outputs.iter().take(4).enumerate() {
            out[174 + port] = PORT_OUTPUT_DMX;
            // GoodInput (178..182) stays 0: no inputs.
            out[182 + port] = if self.receiving[port] { 0x80 } else { 0 };
            out[190 + port] = universe & 0x0f;
        }
        // AcnPriority 194, SwMacro 195, SwRemote 196, spare 197..200: 0.
        out[200] = STYLE_NODE;
        out[201..207].copy_from_slice(&self.mac);
        out[207..211].copy_from_slice(&self.bind_ip);
        out[211] = self.bind_index;
        out[212] = STATUS2;
        // GoodOutputB 213..217: bit 6 = continuous output (we take every packet).
        for port in 0..ports {
            out[213 + port] = 0x40;
        }
        // Status3, responder UID, user, refresh rate, filler: 0.
        out
    }
}

impl PollReply {
    /// Reads an `ArtPollReply` (another node's, or the bridge's own in its tests):
    /// `None` unless `datagram` is one of at least the 207 bytes up to the MAC; the
    /// bind IP and index are read when present. The output ports are those whose
    /// PortTypes say "output" among the first `NumPorts`.
    #[must_use]
    pub fn decode(datagram: &[u8]) -> Option<Self> {
        if datagram.len() < 207
            || datagram[..ID.len()] != ID
            || u16::from_le_bytes([datagram[8], datagram[9]]) != OP_POLL_REPLY
        {
            return None;
        }
        let text = |field: &[u8]| {
            let end = field
                .iter()
                .position(|&byte| byte == 0)
                .unwrap_or(field.len());
            String::from_utf8_lossy(&field[..end]).into_owned()
        };
        let ports = usize::from(u16::from_be_bytes([datagram[172], datagram[173]])).min(4);
        let mut outputs = Vec::new();
        let mut receiving = [false; 4];
        for port in 0..ports {
            if datagram[174 + port] & PORT_OUTPUT_DMX != 0 {
                receiving[outputs.len()] = datagram[182 + port] & 0x80 != 0;
                outputs.push(datagram[190 + port] & 0x0f);
            }
        }
        let mut ip = [0; 4];
        ip.copy_from_slice(&datagram[10..14]);
        let mut mac = [0; 6];
        mac.copy_from_slice(&datagram[201..207]);
        let mut bind_ip = [0; 4];
        if let Some(bind) = datagram.get(207..211) {
            bind_ip.copy_from_slice(bind);
        }
        Some(Self {
            ip,
            version: u16::from_be_bytes([datagram[16], datagram[17]]),
            net: datagram[18] & 0x7f,
            sub_net: datagram[19] & 0x0f,
            oem: u16::from_be_bytes([datagram[20], datagram[21]]),
            esta: u16::from_le_bytes([datagram[24], datagram[25]]),
            short_name: text(&datagram[26..44]),
            long_name: text(&datagram[44..108]),
            node_report: text(&datagram[108..172]),
            outputs,
            receiving,
            mac,
            bind_ip,
            bind_index: datagram.get(211).copied().unwrap_or(0),
        })
    }

    /// The universes of its output ports (numbered from 1, as [`PortAddress::universe`]).
    #[must_use]
    pub fn universes(&self) -> Vec<u16> {
        self.outputs
            .iter()
            .filter_map(|&low| PortAddress::new(self.net, self.sub_net, low & 0x0f))
            .map(PortAddress::universe)
            .collect()
    }
}

/// Writes `text` into a fixed, NUL-terminated field (cut at a character boundary).
fn put_text(field: &mut [u8], text: &str) {
    let max = field.len() - 1;
    let mut end = text.len().min(max);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    field[..end].copy_from_slice(&text.as_bytes()[..end]);
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    /// An `ArtDmx` to Port-Address 1:2:3 with 4 slots, byte by byte as Art-Net 4's
    /// table of `ArtDmx` fields lays it out.
    const DMX: [u8; 22] = [
        b'A', b'r', b't', b'-', b'N', b'e', b't', 0, // ID
        0x00, 0x50, // OpCode 0x5000, little-endian
        0x00, 0x0e, // ProtVer 14, big-endian
        0x07, // Sequence
        0x01, // Physical
        0x23, // SubUni: sub-net 2, universe 3
        0x01, // Net 1
        0x00, 0x04, // Length 4, big-endian
        0xff, 0x80, 0x00, 0x01,
    ];

    #[test]
    fn reads_back_every_poll_reply_it_writes() {
        let template = PollReply {
            ip: [10, 0, 0, 9],
            version: 3,
            net: 0,
            sub_net: 0,
            oem: OEM_UNKNOWN,
            esta: ESTA_PROTOTYPE,
            short_name: "Floatball".to_owned(),
            long_name: "Floatball long".to_owned(),
            node_report: "#0001 [0001] ok".to_owned(),
            outputs: Vec::new(),
            receiving: [false; 4],
            mac: [1, 2, 3, 4, 5, 6],
            bind_ip: [0; 4],
            bind_index: 0,
        };
        let mut replies = PollReply::for_universes(&template, &[1, 2, 3, 4, 5, 300]);
        replies[0].receiving = [true, false, true, false];
        let mut universes = Vec::new();
        for reply in &replies {
            let read = PollReply::decode(&reply.encode()).expect("a poll reply");
            assert_eq!(&read, reply);
            universes.extend(read.universes());
        }
        assert_eq!(universes, [1, 2, 3, 4, 5, 300]);
        assert_eq!(PollReply::decode(&replies[0].encode()[..206]), None);
        assert_eq!(PollReply::decode(&DMX), None);
    }

    #[test]
    fn reads_an_art_dmx_packet() {
        let Ok(Packet::Dmx(dmx)) = decode(&DMX) else {
            panic!("{:?}", decode(&DMX));
        };
        assert_eq!(dmx.sequence, 7);
        assert_eq!(dmx.physical, 1);
        assert_eq!(dmx.port_address, PortAddress::new(1, 2, 3).unwrap());
        assert_eq!(dmx.port_address.raw(), 0x123);
        assert_eq!(dmx.port_address.universe(), 0x124);
        assert_eq!(dmx.data, &[0xff, 0x80, 0x00, 0x01]);
        assert_eq!(encode_dmx(7, dmx.port_address, dmx.data)[..12], DMX[..12]);
        let mut again = encode_dmx(7, dmx.port_address, dmx.data);
        again[13] = 1;
        assert_eq!(again, DMX);
    }

    #[test]
    fn refuses_every_malformed_art_dmx() {
        let with = |at: usize, value: u8| {
            let mut packet = DMX;
            packet[at] = value;
            packet
        };
        assert_eq!(decode(&with(0, b'a')), Err(ArtNetError::BadId));
        assert_eq!(
            decode(&with(11, 13)),
            Err(ArtNetError::OldVersion { version: 13 })
        );
        assert!(
            matches!(decode(&with(10, 1)), Ok(Packet::Dmx(_))),
            "version 270"
        );
        assert_eq!(
            decode(&with(17, 3)),
            Err(ArtNetError::BadLength { length: 3 })
        );
        assert_eq!(
            decode(&with(17, 0)),
            Err(ArtNetError::BadLength { length: 0 })
        );
        let mut long = with(16, 2);
        long[17] = 2; // 514
        assert_eq!(decode(&long), Err(ArtNetError::BadLength { length: 514 }));
        assert_eq!(
            decode(&with(15, 0x80)),
            Err(ArtNetError::BadNet { net: 0x80 })
        );
        assert_eq!(
            decode(&with(17, 6)),
            Err(ArtNetError::Truncated {
                len: 22,
                needed: 24
            })
        );
        assert_eq!(
            decode(&DMX[..17]),
            Err(ArtNetError::Truncated {
                len: 17,
                needed: 18
            })
        );
        assert_eq!(
            decode(&DMX[..11]),
            Err(ArtNetError::Truncated {
                len: 11,
                needed: 12
            })
        );
        assert_eq!(
            decode(&DMX[..3]),
            Err(ArtNetError::Truncated { len: 3, needed: 12 })
        );
        assert_eq!(decode(b"Art-Nit\0\0\x50"), Err(ArtNetError::BadId));
        assert_eq!(decode(b"Art-Nit\0"), Err(ArtNetError::BadId));
        // Trailing bytes after the data are tolerated.
        let mut padded = DMX.to_vec();
        padded.extend_from_slice(&[0; 3]);
        assert!(matches!(decode(&padded), Ok(Packet::Dmx(dmx)) if dmx.data.len() == 4));
    }

    #[test]
    fn reads_polls_short_and_long_and_passes_other_op_codes() {
        // Art-Net 4's ArtPoll: flags 0x02 (reply on change), DiagPriority 0x10.
        let poll = [
            b'A', b'r', b't', b'-', b'N', b'e', b't', 0, 0x00, 0x20, 0x00, 0x0e, 0x02, 0x10,
        ];
        assert_eq!(
            decode(&poll),
            Ok(Packet::Poll(ArtPoll {
                flags: 2,
                diag_priority: 0x10
            }))
        );
        assert_eq!(
            encode_poll(ArtPoll {
                flags: 2,
                diag_priority: 0x10
            }),
            poll
        );
        // 12 bytes: accepted, missing fields zero.
        assert_eq!(
            decode(&poll[..12]),
            Ok(Packet::Poll(ArtPoll {
                flags: 0,
                diag_priority: 0
            }))
        );
        // An ArtSync (0x5200) is no DMX: passed on as Other.
        let sync = [
            b'A', b'r', b't', b'-', b'N', b'e', b't', 0, 0x00, 0x52, 0x00, 0x0e, 0, 0,
        ];
        assert_eq!(decode(&sync), Ok(Packet::Other { op_code: 0x5200 }));
    }

    #[test]
    fn port_addresses_split_and_number_universes_from_one() {
        let address = PortAddress::new(0x7f, 0xf, 0xf).unwrap();
        assert_eq!(address.raw(), 0x7fff);
        assert_eq!(address.universe(), 32768);
        assert_eq!(PortAddress::of_universe(1), PortAddress::new(0, 0, 0));
        assert_eq!(PortAddress::of_universe(0), None);
        assert_eq!(PortAddress::of_universe(32769), None);
        assert_eq!(PortAddress::new(128, 0, 0), None);
        assert_eq!(PortAddress::new(0, 16, 0), None);
        let address = PortAddress::of_universe(0x124).unwrap();
        assert_eq!(
            (address.net(), address.sub_net(), address.universe_low()),
            (1, 2, 3)
        );
    }

    fn template() -> PollReply {
        PollReply {
            ip: [192, 168, 1, 20],
            version: 0x0102,
            net: 0,
            sub_net: 0,
            oem: OEM_UNKNOWN,
            esta: ESTA_PROTOTYPE,
            short_name: "Floatball".into(),
            long_name:
                "Floatball kinetic matrix bridge, a name longer than sixty-three bytes is cut"
                    .into(),
            node_report: "#0001 [0001] Power On Tests successful".into(),
            outputs: Vec::new(),
            receiving: [true, false, false, false],
            mac: [0x02, 0, 0, 0, 0, 0x01],
            bind_ip: [0; 4],
            bind_index: 0,
        }
    }

    #[test]
    fn the_poll_reply_has_art_net_4s_layout() {
        let replies = PollReply::for_universes(&template(), &[1, 2, 0x124]);
        assert_eq!(
            replies.len(),
            2,
            "0:0:0 and 0:0:1 share a reply, 1:2:3 its own"
        );
        let reply = replies[0].encode();
        assert_eq!(reply.len(), 239);
        assert_eq!(&reply[..8], b"Art-Net\0");
        assert_eq!(reply[8..10], [0x00, 0x21], "OpPollReply, little-endian");
        assert_eq!(reply[10..14], [192, 168, 1, 20]);
        assert_eq!(reply[14..16], [0x36, 0x19], "port 0x1936, little-endian");
        assert_eq!(reply[16..18], [0x01, 0x02]);
        assert_eq!(reply[18..20], [0, 0], "Net and Sub-Net switches");
        assert_eq!(reply[20..22], [0x00, 0xff], "OEM, big-endian");
        assert_eq!(reply[23], 0xe0);
        assert_eq!(reply[24..26], [0xf0, 0x7f], "ESTA, little-endian");
        assert_eq!(&reply[26..36], b"Floatball\0");
        assert_eq!(reply[43], 0, "short name NUL-terminated");
        assert_eq!(reply[107], 0, "long name cut to 63 bytes");
        assert_eq!(&reply[44..107], &template().long_name.as_bytes()[..63]);
        assert_eq!(&reply[108..113], b"#0001");
        assert_eq!(reply[172..174], [0, 2], "NumPorts, big-endian");
        assert_eq!(
            reply[174..178],
            [0x80, 0x80, 0, 0],
            "outputs from Art-Net, DMX512"
        );
        assert_eq!(reply[178..182], [0; 4], "no inputs");
        assert_eq!(reply[182..186], [0x80, 0, 0, 0], "GoodOutputA");
        assert_eq!(reply[186..190], [0; 4], "SwIn");
        assert_eq!(reply[190..194], [0, 1, 0, 0], "SwOut");
        assert_eq!(reply[200], 0, "StNode");
        assert_eq!(reply[201..207], [0x02, 0, 0, 0, 0, 0x01]);
        assert_eq!(reply[207..211], [192, 168, 1, 20], "BindIp");
        assert_eq!(reply[211], 1, "BindIndex");
        assert_eq!(reply[212] & 0x08, 0x08, "Status2: 15-bit Port-Addresses");
        assert_eq!(reply[213..217], [0x40, 0x40, 0, 0]);
        assert!(reply[217..].iter().all(|&b| b == 0));
        let second = replies[1].encode();
        assert_eq!(second[18..20], [1, 2]);
        assert_eq!(second[190], 3);
        assert_eq!(second[211], 2);
        // Its own decoder sees a reply as another OpCode, not an error.
        assert_eq!(decode(&reply), Ok(Packet::Other { op_code: 0x2100 }));
    }

    #[test]
    fn more_than_four_universes_of_one_sub_net_take_several_replies() {
        let universes: Vec<u16> = (1..=10).collect();
        let replies = PollReply::for_universes(&template(), &universes);
        let ports: Vec<usize> = replies.iter().map(|reply| reply.outputs.len()).collect();
        assert_eq!(ports, [4, 4, 2]);
        assert_eq!(replies[2].outputs, [8, 9]);
        let none = PollReply::for_universes(&template(), &[0, 40000]);
        assert_eq!(none.len(), 1, "no Art-Net universe: one reply, no ports");
        assert_eq!(none[0].encode()[172..178], [0; 6]);
        let cut = "é".repeat(40);
        let mut named = template();
        named.short_name = cut;
        let reply = named.encode();
        assert_eq!(reply[26 + 16], 0, "17 bytes would cut a character: 16 sent");
    }
}
