//! sACN (ANSI E1.31-2018, "Streaming ACN") receive side, sans-IO: [`decode`] reads one
//! UDP datagram (port 5568) into a [`DataPacket`] or recognises a universe discovery
//! or synchronisation packet (root vector `VECTOR_ROOT_E131_EXTENDED`, 0x8), which a
//! receiver that outputs every packet at once ignores; [`multicast_address`] gives the
//! group a universe is sent to; [`sequence_accepts`] is E1.31 §6.7.2's rule for
//! out-of-order packets; [`NETWORK_DATA_LOSS_MS`] is how long a source may stay silent
//! before it is dropped (the merge, [`super::merge`], applies it and stream
//! termination).
//!
//! A data packet's layout (E1.31 Table 4-1), all big-endian:
//!
//! | layer | bytes |
//! |---|---|
//! | root | preamble size 0x0010 (0–1), post-amble size 0 (2–3), ACN packet identifier `"ASC-E1.17\0\0\0"` (4–15), flags & length (16–17), vector 0x00000004 (18–21), CID (22–37) |
//! | framing | flags & length (38–39), vector 0x00000002 (40–43), source name, 64 bytes UTF-8 NUL-terminated (44–107), priority 0–200 (108), synchronisation address (109–110), sequence number (111), options (112: bit 7 preview data, bit 6 stream terminated, bit 5 force synchronisation), universe 1–63999 (113–114) |
//! | DMP | flags & length (115–116), vector 0x02 (117), address & data type 0xa1 (118), first property address 0 (119–120), address increment 1 (121–122), property value count 1–513 (123–124), start code (125), data (126…) |
//!
//! Each flags & length field is 0x7 in its top 4 bits and, in its low 12, the length
//! of its layer from that field to the end of the packet; this decoder requires them
//! to agree with the datagram's length.
//!
//! Written by hand, like [`super::artnet`] and for the same reasons: the crates (`sacn`)
//! are built around their own sockets and threads; the receive side is one fixed
//! layout here, with typed refusals ([`SacnError`]) and no panic on any input.

use thiserror::Error;

/// The UDP port of sACN.
pub const PORT: u16 = 5568;

/// The ACN packet identifier.
pub const ACN_PACKET_IDENTIFIER: [u8; 12] = *b"ASC-E1.17\0\0\0";

/// Root layer vector of a data packet.
pub const VECTOR_ROOT_E131_DATA: u32 = 0x0000_0004;
/// Root layer vector of synchronisation and universe discovery packets.
pub const VECTOR_ROOT_E131_EXTENDED: u32 = 0x0000_0008;
/// Framing layer vector of a data packet.
pub const VECTOR_E131_DATA_PACKET: u32 = 0x0000_0002;
/// Framing layer vector of a synchronisation packet (extended).
pub const VECTOR_E131_EXTENDED_SYNCHRONIZATION: u32 = 0x0000_0001;
/// Framing layer vector of a universe discovery packet (extended).
pub const VECTOR_E131_EXTENDED_DISCOVERY: u32 = 0x0000_0002;
/// DMP layer vector.
pub const VECTOR_DMP_SET_PROPERTY: u8 = 0x02;
/// DMP address type and data type.
pub const DMP_ADDRESS_DATA_TYPE: u8 = 0xa1;

/// Highest priority a source may send.
pub const MAX_PRIORITY: u8 = 200;
/// The priority of a source that does not say (and of Art-Net in the merge).
pub const DEFAULT_PRIORITY: u8 = 100;
/// Highest data universe.
pub const MAX_UNIVERSE: u16 = 63999;
/// E1.31's network data loss timeout: a source silent this long is dropped.
pub const NETWORK_DATA_LOSS_MS: u64 = 2500;

/// Offset of the DMX data (after the start code).
pub const DATA_OFFSET: usize = 126;
/// The shortest data packet (no slot beyond the start code).
pub const MIN_DATA_LEN: usize = DATA_OFFSET;
/// The longest data packet (512 slots).
pub const MAX_DATA_LEN: usize = DATA_OFFSET + 512;

/// Options bit: preview data (for visualisers, not for live output).
pub const OPTION_PREVIEW: u8 = 0x80;
/// Options bit: the source stops sending this universe.
pub const OPTION_TERMINATED: u8 = 0x40;
/// Options bit: force synchronisation.
pub const OPTION_FORCE_SYNC: u8 = 0x20;

/// A data packet's framing options.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Options {
    /// Preview data: meant for visualisers; the merge does not output it.
    pub preview: bool,
    /// Stream terminated: the source leaves this universe now.
    pub terminated: bool,
    /// Force synchronisation.
    pub force_sync: bool,
}

impl Options {
    /// From the options byte.
    #[must_use]
    pub const fn from_byte(byte: u8) -> Self {
        Self {
            preview: byte & OPTION_PREVIEW != 0,
            terminated: byte & OPTION_TERMINATED != 0,
            force_sync: byte & OPTION_FORCE_SYNC != 0,
        }
    }

    /// The options byte.
    #[must_use]
    pub const fn byte(self) -> u8 {
        (if self.preview { OPTION_PREVIEW } else { 0 })
            | (if self.terminated {
                OPTION_TERMINATED
            } else {
                0
            })
            | (if self.force_sync {
                OPTION_FORCE_SYNC
            } else {
                0
            })
    }
}

/// An E1.31 data packet.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DataPacket<'a> {
    /// The sender's component identifier (a UUID).
    pub cid: [u8; 16],
    /// The source's name, cut at its first NUL (lossy UTF-8).
    pub source_name: &'a [u8],
    /// Priority, 0..=200.
    pub priority: u8,
    /// Universe the source synchronises on (0: none).
    pub sync_address: u16,
    /// Sequence number.
    pub sequence: u8,
    /// Options.
    pub options: Options,
    /// Universe, 1..=63999.
    pub universe: u16,
    /// The DMX start code (0 = dimmer data; others are ignored by the merge).
    pub start_code: u8,
    /// The slots after the start code (0..=512).
    pub data: &'a [u8],
}

/// One decoded sACN datagram.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Packet<'a> {
    /// DMX data.
    Data(DataPacket<'a>),
    /// A universe discovery packet (which universes a source sends): ignored.
    Discovery {
        /// The sender.
        cid: [u8; 16],
    },
    /// A synchronisation packet: ignored (each data packet is used at once).
    Sync {
        /// The sender.
        cid: [u8; 16],
    },
}

/// Which layer a length field belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layer {
    /// The root layer.
    Root,
    /// The framing layer.
    Framing,
    /// The DMP layer.
    Dmp,
}

/// Why a datagram is not an E1.31 packet this receiver can use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum SacnError {
    /// Shorter than a packet's fixed part.
    #[error("truncated: {len} bytes, at least {needed} needed")]
    Truncated {
        /// Bytes received.
        len: usize,
        /// Bytes needed.
        needed: usize,
    },
    /// Longer than a data packet can be.
    #[error("too long: {len} bytes, at most 638")]
    TooLong {
        /// Bytes received.
        len: usize,
    },
    /// The preamble size is not 0x0010 or the post-amble size not 0.
    #[error("preamble {preamble:#06x} / post-amble {postamble:#06x}: 0x0010 / 0 expected")]
    BadPreamble {
        /// Preamble size found.
        preamble: u16,
        /// Post-amble size found.
        postamble: u16,
    },
    /// Not `"ASC-E1.17\0\0\0"`.
    #[error("not ACN (bad packet identifier)")]
    BadIdentifier,
    /// A flags & length field whose flags are not 0x7 or whose length disagrees with
    /// the datagram.
    #[error(
        "{layer:?} layer flags & length {field:#06x}: flags 0x7 and length {expected} expected"
    )]
    BadLength {
        /// The layer.
        layer: Layer,
        /// The field.
        field: u16,
        /// The length the datagram gives the layer.
        expected: usize,
    },
    /// An unknown root vector.
    #[error("root vector {vector:#x}: 0x4 (data) or 0x8 (extended) expected")]
    BadRootVector {
        /// The vector.
        vector: u32,
    },
    /// An unknown framing vector.
    #[error("framing vector {vector:#x} unknown")]
    BadFramingVector {
        /// The vector.
        vector: u32,
    },
    /// The DMP layer's vector, address type, first address or increment is not the
    /// one E1.31 fixes.
    #[error("DMP layer: vector 0x02, type 0xa1, first address 0, increment 1 expected")]
    BadDmp,
    /// The property value count disagrees with the DMP layer's length.
    #[error("property value count {count}: {expected} expected")]
    BadCount {
        /// The count found.
        count: u16,
        /// The count the length gives.
        expected: usize,
    },
    /// A priority above 200.
    #[error("priority {priority} above 200")]
    BadPriority {
        /// The priority.
        priority: u8,
    },
    /// A data universe outside 1..=63999.
    #[error("universe {universe} outside 1-63999")]
    BadUniverse {
        /// The universe.
        universe: u16,
    },
}

/// The IPv4 multicast group a universe is sent to: 239.255.hi.lo.
#[must_use]
pub const fn multicast_address(universe: u16) -> [u8; 4] {
    let [hi, lo] = universe.to_be_bytes();
    [239, 255, hi, lo]
}

/// E1.31 §6.7.2: a packet whose sequence number is `new` after one with `last` from
/// the same source and universe is processed when the signed 8-bit difference
/// `new - last` is above 0 (newer) or at most -20 (the source restarted); otherwise
/// it came out of order and is dropped.
#[must_use]
pub const fn sequence_accepts(last: u8, new: u8) -> bool {
    let difference = new.wrapping_sub(last) as i8;
    difference > 0 || difference <= -20
}

fn be16(bytes: &[u8], at: usize) -> u16 {
    u16::from_be_bytes([bytes[at], bytes[at + 1]])
}

fn be32(bytes: &[u8], at: usize) -> u32 {
    u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}

/// Checks the flags & length field at `at`: flags 0x7, length = the rest of the
/// datagram.
fn check_length(datagram: &[u8], at: usize, layer: Layer) -> Result<(), SacnError> {
    let field = be16(datagram, at);
    let expected = datagram.len() - at;
    if field >> 12 != 0x7 || usize::from(field & 0x0fff) != expected {
        return Err(SacnError::BadLength {
            layer,
            field,
            expected,
        });
    }
    Ok(())
}

/// Reads one datagram.
///
/// # Errors
/// [`SacnError`] for anything that is not a usable E1.31 packet.
pub fn decode(datagram: &[u8]) -> Result<Packet<'_>, SacnError> {
    const ROOT_LEN: usize = 38;
    let len = datagram.len();
    if len < ROOT_LEN + 6 {
        return Err(SacnError::Truncated {
            len,
            needed: ROOT_LEN + 6,
        });
    }
    if len > MAX_DATA_LEN {
        // Discovery packets are at most 120 + 2 × 512 bytes.
        if !(len <= 1144 && be32(datagram, 18) == VECTOR_ROOT_E131_EXTENDED) {
            return Err(SacnError::TooLong { len });
        }
    }
    let (preamble, postamble) = (be16(datagram, 0), be16(datagram, 2));
    if preamble != 0x0010 || postamble != 0 {
        return Err(SacnError::BadPreamble {
            preamble,
            postamble,
        });
    }
    if datagram[4..16] != ACN_PACKET_IDENTIFIER {
        return Err(SacnError::BadIdentifier);
    }
    check_length(datagram, 16, Layer::Root)?;
    let mut cid = [0u8; 16];
    cid.copy_from_slice(&datagram[22..38]);
    check_length(datagram, 38, Layer::Framing)?;
    let framing_vector = be32(datagram, 40);
    match be32(datagram, 18) {
        VECTOR_ROOT_E131_DATA => {}
        VECTOR_ROOT_E131_EXTENDED => {
            return match framing_vector {
                VECTOR_E131_EXTENDED_DISCOVERY => Ok(Packet::Discovery { cid }),
                VECTOR_E131_EXTENDED_SYNCHRONIZATION => Ok(Packet::Sync { cid }),
                vector => Err(SacnError::BadFramingVector { vector }),
            };
        }
        vector => return Err(SacnError::BadRootVector { vector }),
    }
    if framing_vector != VECTOR_E131_DATA_PACKET {
        return Err(SacnError::BadFramingVector {
            vector: framing_vector,
        });
    }
    if len < MIN_DATA_LEN {
        return Err(SacnError::Truncated {
            len,
            needed: MIN_DATA_LEN,
        });
    }
    check_length(datagram, 115, Layer::Dmp)?;
    if datagram[117] != VECTOR_DMP_SET_PROPERTY
        || datagram[118] != DMP_ADDRESS_DATA_TYPE
        || be16(datagram, 119) != 0
        || be16(datagram, 121) != 1
    {
        return Err(SacnError::BadDmp);
    }
    let count = be16(datagram, 123);
    if usize::from(count) != len - 125 {
        return Err(SacnError::BadCount {
            count,
            expected: len - 125,
        });
    }
    let priority = datagram[108];
    if priority > MAX_PRIORITY {
        return Err(SacnError::BadPriority { priority });
    }
    let universe = be16(datagram, 113);
    if universe == 0 || universe > MAX_UNIVERSE {
        return Err(SacnError::BadUniverse { universe });
    }
    let name = &datagram[44..108];
    let name_len = name
        .iter()
        .position(|&byte| byte == 0)
        .unwrap_or(name.len());
    Ok(Packet::Data(DataPacket {
        cid,
        source_name: &name[..name_len],
        priority,
        sync_address: be16(datagram, 109),
        sequence: datagram[111],
        options: Options::from_byte(datagram[112]),
        universe,
        start_code: datagram[125],
        data: &datagram[DATA_OFFSET..],
    }))
}

/// Encodes a data packet (for tests, fuzzing and a simulated console): the name is
/// cut to 63 bytes, the data to 512 slots.
#[must_use]
pub fn encode_data(packet: &DataPacket<'_>) -> Vec<u8> {
    let data = &packet.data[..packet.data.len().min(512)];
    let len = DATA_OFFSET + data.len();
    let mut out = Vec::with_capacity(len);
    out.extend_from_slice(&0x0010u16.to_be_bytes());
    out.extend_from_slice(&0u16.to_be_bytes());
    out.extend_from_slice(&ACN_PACKET_IDENTIFIER);
    out.extend_from_slice(&flags_length(len - 16));
    out.extend_from_slice(&VECTOR_ROOT_E131_DATA.to_be_bytes());
    out.extend_from_slice(&packet.cid);
    out.extend_from_slice(&flags_length(len - 38));
    out.extend_from_slice(&VECTOR_E131_DATA_PACKET.to_be_bytes());
    let mut name = [0u8; 64];
    let name_len = packet.source_name.len().min(63);
    name[..name_len].copy_from_slice(&packet.source_name[..name_len]);
    out.extend_from_slice(&name);
    out.push(packet.priority);
    out.extend_from_slice(&packet.sync_address.to_be_bytes());
    out.push(packet.sequence);
    out.push(packet.options.byte());
    out.extend_from_slice(&packet.universe.to_be_bytes());
    out.extend_from_slice(&flags_length(len - 115));
    out.extend_from_slice(&[VECTOR_DMP_SET_PROPERTY, DMP_ADDRESS_DATA_TYPE, 0, 0, 0, 1]);
    out.extend_from_slice(&((data.len() + 1) as u16).to_be_bytes());
    out.push(packet.start_code);
    out.extend_from_slice(data);
    out
}

/// Encodes a universe discovery packet listing `universes` (page 0 of 0).
#[must_use]
pub fn encode_discovery(cid: [u8; 16], universes: &[u16]) -> Vec<u8> {
    let universes = &universes[..universes.len().min(512)];
    let len = 120 + 2 * universes.len();
    let mut out = Vec::with_capacity(len);
    out.extend_from_slice(&0x0010u16.to_be_bytes());
    out.extend_from_slice(&0u16.to_be_bytes());
    out.extend_from_slice(&ACN_PACKET_IDENTIFIER);
    out.extend_from_slice(&flags_length(len - 16));
    out.extend_from_slice(&VECTOR_ROOT_E131_EXTENDED.to_be_bytes());
    out.extend_from_slice(&cid);
    out.extend_from_slice(&flags_length(len - 38));
    out.extend_from_slice(&VECTOR_E131_EXTENDED_DISCOVERY.to_be_bytes());
    out.extend_from_slice(&[0; 64]); // source name
    out.extend_from_slice(&[0; 4]); // reserved
    out.extend_from_slice(&flags_length(len - 112));
    out.extend_from_slice(&1u32.to_be_bytes()); // VECTOR_UNIVERSE_DISCOVERY_UNIVERSE_LIST
    out.extend_from_slice(&[0, 0]); // page, last page
    for universe in universes {
        out.extend_from_slice(&universe.to_be_bytes());
    }
    out
}

fn flags_length(length: usize) -> [u8; 2] {
    (0x7000 | (length as u16 & 0x0fff)).to_be_bytes()
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    const CID: [u8; 16] = [
        0xef, 0x07, 0xc8, 0xdd, 0x00, 0x64, 0x44, 0x01, 0xa3, 0xa2, 0x45, 0x9e, 0xf8, 0xe6, 0x14,
        0x3e,
    ];

    /// A data packet for universe 1 with 3 slots, laid out field by field as E1.31-2018
    /// Table 4-1 gives them.
    fn table_4_1() -> Vec<u8> {
        let mut packet = vec![
            0x00, 0x10, // preamble size
            0x00, 0x00, // post-amble size
            0x41, 0x53, 0x43, 0x2d, 0x45, 0x31, 0x2e, 0x31, 0x37, 0x00, 0x00, 0x00, 0x70,
            0x71, // flags & length: 0x7, 129 - 16 = 113
            0x00, 0x00, 0x00, 0x04, // VECTOR_ROOT_E131_DATA
        ];
        packet.extend_from_slice(&CID);
        packet.extend_from_slice(&[0x70, 0x5b]); // 129 - 38 = 91
        packet.extend_from_slice(&[0x00, 0x00, 0x00, 0x02]); // VECTOR_E131_DATA_PACKET
        let mut name = [0u8; 64];
        name[..9].copy_from_slice(b"Console 1");
        packet.extend_from_slice(&name);
        packet.extend_from_slice(&[
            150, // priority
            0x00, 0x00, // sync address
            0x2a, // sequence number
            0x00, // options
            0x00, 0x01, // universe 1
            0x70, 0x0e, // DMP flags & length: 129 - 115 = 14
            0x02, 0xa1, // vector, address & data type
            0x00, 0x00, // first property address
            0x00, 0x01, // address increment
            0x00, 0x04, // property value count: start code + 3 slots
            0x00, // start code
            0xff, 0x00, 0x80,
        ]);
        packet
    }

    #[test]
    fn reads_a_data_packet_laid_out_as_the_standard_says() {
        let bytes = table_4_1();
        assert_eq!(bytes.len(), 129);
        let Ok(Packet::Data(packet)) = decode(&bytes) else {
            panic!("{:?}", decode(&bytes));
        };
        assert_eq!(packet.cid, CID);
        assert_eq!(packet.source_name, b"Console 1");
        assert_eq!(packet.priority, 150);
        assert_eq!(packet.sequence, 0x2a);
        assert_eq!(packet.options, Options::default());
        assert_eq!(packet.universe, 1);
        assert_eq!(packet.start_code, 0);
        assert_eq!(packet.data, &[0xff, 0x00, 0x80]);
        assert_eq!(encode_data(&packet), bytes, "encodes back byte for byte");
    }

    #[test]
    fn reads_the_options_and_a_full_universe() {
        let data = [7u8; 512];
        let packet = DataPacket {
            cid: CID,
            source_name: b"",
            priority: 200,
            sync_address: 7,
            sequence: 255,
            options: Options {
                preview: true,
                terminated: true,
                force_sync: true,
            },
            universe: MAX_UNIVERSE,
            start_code: 0xdd,
            data: &data,
        };
        let bytes = encode_data(&packet);
        assert_eq!(bytes.len(), 638);
        assert_eq!(bytes[112], 0xe0);
        assert_eq!(decode(&bytes), Ok(Packet::Data(packet)));
    }

    #[test]
    fn refuses_every_malformation() {
        let with = |at: usize, value: u8| {
            let mut packet = table_4_1();
            packet[at] = value;
            decode(&packet).map(|_| ())
        };
        assert_eq!(
            with(1, 0x11),
            Err(SacnError::BadPreamble {
                preamble: 0x11,
                postamble: 0
            })
        );
        assert_eq!(
            with(3, 1),
            Err(SacnError::BadPreamble {
                preamble: 0x10,
                postamble: 1
            })
        );
        assert_eq!(with(8, b'X'), Err(SacnError::BadIdentifier));
        assert_eq!(
            with(16, 0x60),
            Err(SacnError::BadLength {
                layer: Layer::Root,
                field: 0x6071,
                expected: 113
            })
        );
        assert_eq!(
            with(17, 0x72),
            Err(SacnError::BadLength {
                layer: Layer::Root,
                field: 0x7072,
                expected: 113
            })
        );
        assert_eq!(with(21, 5), Err(SacnError::BadRootVector { vector: 5 }));
        assert!(matches!(
            with(39, 0x5c),
            Err(SacnError::BadLength {
                layer: Layer::Framing,
                ..
            })
        ));
        assert_eq!(with(43, 3), Err(SacnError::BadFramingVector { vector: 3 }));
        assert!(matches!(
            with(116, 0x0f),
            Err(SacnError::BadLength {
                layer: Layer::Dmp,
                ..
            })
        ));
        assert_eq!(with(117, 1), Err(SacnError::BadDmp));
        assert_eq!(with(118, 0xa2), Err(SacnError::BadDmp));
        assert_eq!(with(120, 1), Err(SacnError::BadDmp));
        assert_eq!(with(122, 2), Err(SacnError::BadDmp));
        assert_eq!(
            with(124, 5),
            Err(SacnError::BadCount {
                count: 5,
                expected: 4
            })
        );
        assert_eq!(
            with(108, 201),
            Err(SacnError::BadPriority { priority: 201 })
        );
        assert_eq!(with(114, 0), Err(SacnError::BadUniverse { universe: 0 }));
        let mut high = table_4_1();
        high[113..115].copy_from_slice(&64000u16.to_be_bytes());
        assert_eq!(
            decode(&high),
            Err(SacnError::BadUniverse { universe: 64000 })
        );
        let bytes = table_4_1();
        assert_eq!(
            decode(&bytes[..40]),
            Err(SacnError::Truncated {
                len: 40,
                needed: 44
            })
        );
        // Cut short with every length field consistent: still too short for DMP.
        let mut short = bytes[..120].to_vec();
        short[16..18].copy_from_slice(&flags_length(120 - 16));
        short[38..40].copy_from_slice(&flags_length(120 - 38));
        assert_eq!(
            decode(&short),
            Err(SacnError::Truncated {
                len: 120,
                needed: 126
            })
        );
        let mut long = bytes.clone();
        long.resize(700, 0);
        assert_eq!(decode(&long), Err(SacnError::TooLong { len: 700 }));
    }

    #[test]
    fn discovery_and_sync_packets_are_recognised_and_ignored() {
        let discovery = encode_discovery(CID, &[1, 2, 3]);
        assert_eq!(discovery.len(), 126);
        assert_eq!(decode(&discovery), Ok(Packet::Discovery { cid: CID }));
        // A full discovery page (512 universes) is longer than any data packet.
        let universes: Vec<u16> = (1..=512).collect();
        let full = encode_discovery(CID, &universes);
        assert_eq!(full.len(), 1144);
        assert_eq!(decode(&full), Ok(Packet::Discovery { cid: CID }));
        // A synchronisation packet: root 0x8, framing vector 0x1, 49 bytes.
        let mut sync = discovery[..49].to_vec();
        sync[16..18].copy_from_slice(&flags_length(49 - 16));
        sync[38..40].copy_from_slice(&flags_length(49 - 38));
        sync[40..44].copy_from_slice(&VECTOR_E131_EXTENDED_SYNCHRONIZATION.to_be_bytes());
        assert_eq!(decode(&sync), Ok(Packet::Sync { cid: CID }));
        sync[43] = 9;
        assert_eq!(
            decode(&sync),
            Err(SacnError::BadFramingVector { vector: 9 })
        );
    }

    #[test]
    fn multicast_groups_are_239_255_hi_lo() {
        assert_eq!(multicast_address(1), [239, 255, 0, 1]);
        assert_eq!(multicast_address(256), [239, 255, 1, 0]);
        assert_eq!(multicast_address(63999), [239, 255, 249, 255]);
    }

    #[test]
    fn the_sequence_rule_of_6_7_2() {
        assert!(sequence_accepts(10, 11));
        assert!(sequence_accepts(255, 0), "wraps");
        assert!(sequence_accepts(250, 5));
        assert!(!sequence_accepts(10, 10), "a duplicate");
        assert!(!sequence_accepts(10, 9), "one late");
        assert!(!sequence_accepts(10, 247), "-19: out of order");
        assert!(sequence_accepts(10, 246), "-20: the source restarted");
        assert!(sequence_accepts(10, 138), "+128 reads as -128: restarted");
        assert!(sequence_accepts(10, 137), "+127");
    }
}
