//! OSC packets read strictly as OSC 1.0 defines them (issue 52): a packet is taken
//! whole or refused whole, and a message's arguments only ever come from its own
//! bytes.
//!
//! The `rosc` crate's decoder was at fault: it stops reading a bundle at the first
//! element it cannot read and keeps what it read before, and an element's size that
//! is not a multiple of 4 slips the reading of the rest, so a malformed element could
//! hand the next message's address someone else's (or no) arguments — a refused
//! `/floatball/start 1 -inf` was carried out as a Start from the beginning. This
//! reader replaces it; `rosc` still gives the types and encodes the feedback.
//!
//! What OSC 1.0 requires, checked here (each a refusal of the whole packet, with where
//! and why):
//! - every packet and every bundle element is a multiple of 4 bytes long, and an
//!   element's size fits in what is left of its bundle;
//! - an OSC-string is ASCII (here: UTF-8) ending in a NUL and padded with NULs to a
//!   multiple of 4, all padding bytes 0; a blob likewise, its size not negative;
//! - a message is its address (starting with `/`), its type tag string (starting
//!   with `,`) and exactly the data its tags name, nothing left over — the older
//!   form without a type tag string is refused too;
//! - a bundle starts with `#bundle`, has its 8-byte time tag, and its elements are
//!   messages or bundles, nested at most [`MAX_BUNDLE_DEPTH`] deep; arrays in a type
//!   tag string nest at most [`MAX_ARRAY_DEPTH`] deep, their brackets balanced;
//! - the type tags are OSC 1.0's `i f s b` and the common additions `h t d S c r m T
//!   F N I [ ]`; any other tag is refused.

use rosc::{OscArray, OscColor, OscMessage, OscMidiMessage, OscTime, OscType};

/// The largest packet decoded, bytes: a command is tens of bytes, a bundle of a few
/// of them a few hundred. Larger packets are refused unread.
pub const MAX_PACKET_BYTES: usize = 1500;

/// How deeply bundles may nest: a bundle in a bundle is depth 2. Show control
/// systems send one level; deeper is refused.
pub const MAX_BUNDLE_DEPTH: usize = 4;

/// How deeply arrays may nest in a type tag string.
pub const MAX_ARRAY_DEPTH: usize = 4;

/// The messages of a datagram, those of its bundles in order (their time tags are
/// not kept: commands are carried out at once).
///
/// # Errors
/// Why the packet is refused, with the byte offset where reading stopped: too large,
/// or not OSC 1.0 as the [module documentation](self) lists.
pub fn decode(packet: &[u8]) -> Result<Vec<OscMessage>, String> {
    if packet.len() > MAX_PACKET_BYTES {
        return Err(format!(
            "a packet of {} bytes is over the {MAX_PACKET_BYTES} bytes taken",
            packet.len()
        ));
    }
    let mut messages = Vec::new();
    element(packet, 0, 1, &mut messages).map_err(|refusal| format!("not OSC: {refusal}"))?;
    Ok(messages)
}

/// Why a packet is not OSC 1.0: what was wrong, at which byte of the packet.
#[derive(Debug)]
struct Refusal {
    at: usize,
    what: String,
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} (at byte {})", self.what, self.at)
    }
}

/// A refusal at byte `at`.
fn refuse<T>(at: usize, what: impl Into<String>) -> Result<T, Refusal> {
    Err(Refusal {
        at,
        what: what.into(),
    })
}

/// Reads one packet or bundle element, `bytes`, which starts at byte `offset` of the
/// datagram and sits at bundle depth `depth` (the datagram itself: 1), appending its
/// messages to `messages`.
fn element(
    bytes: &[u8],
    offset: usize,
    depth: usize,
    messages: &mut Vec<OscMessage>,
) -> Result<(), Refusal> {
    if !bytes.len().is_multiple_of(4) {
        return refuse(
            offset,
            format!(
                "{} bytes is not a multiple of 4 (OSC 1.0: every packet and element is)",
                bytes.len()
            ),
        );
    }
    match bytes.first() {
        Some(b'#') => bundle(bytes, offset, depth, messages),
        Some(b'/') => {
            messages.push(message(bytes, offset)?);
            Ok(())
        }
        Some(_) => refuse(offset, "neither a message (`/…`) nor a bundle (`#bundle`)"),
        None => refuse(offset, "an empty packet or element"),
    }
}

/// Reads a bundle (see [`element`]).
fn bundle(
    bytes: &[u8],
    offset: usize,
    depth: usize,
    messages: &mut Vec<OscMessage>,
) -> Result<(), Refusal> {
    if depth > MAX_BUNDLE_DEPTH {
        return refuse(
            offset,
            format!("bundles nested over {MAX_BUNDLE_DEPTH} deep"),
        );
    }
    let mut reader = Reader::new(bytes, offset);
    if reader.string()? != "#bundle" {
        return refuse(offset, "a `#` that does not start `#bundle`");
    }
    reader.take(8, "the bundle's time tag")?;
    while !reader.is_empty() {
        let at = reader.at();
        let size = reader.int32("a bundle element's size")?;
        let size = usize::try_from(size)
            .ok()
            .filter(|size| *size > 0)
            .map_or_else(
                || refuse(at, format!("a bundle element's size of {size}")),
                Ok,
            )?;
        if !size.is_multiple_of(4) {
            return refuse(
                at,
                format!("a bundle element's size of {size} is not a multiple of 4"),
            );
        }
        let start = reader.at();
        let content = reader.take(size, "a bundle element (its size is past the bundle's end)")?;
        element(content, start, depth + 1, messages)?;
    }
    Ok(())
}

/// Reads a message: address, type tags, exactly the data they name.
fn message(bytes: &[u8], offset: usize) -> Result<OscMessage, Refusal> {
    let mut reader = Reader::new(bytes, offset);
    let addr = reader.string()?.to_owned();
    if reader.is_empty() {
        return refuse(
            reader.at(),
            "a message without a type tag string (the older form is not taken)",
        );
    }
    let tags_at = reader.at();
    let tags = reader.string()?;
    let Some(tags) = tags.strip_prefix(',') else {
        return refuse(tags_at, "a type tag string that does not start with `,`");
    };
    let mut tags = tags.bytes();
    let args = arguments(&mut reader, &mut tags, tags_at, 0)?;
    if !reader.is_empty() {
        return refuse(
            reader.at(),
            format!(
                "{} bytes after the data the type tags name",
                bytes.len() - (reader.at() - offset)
            ),
        );
    }
    Ok(OscMessage { addr, args })
}

/// Reads the arguments `tags` name, to the end of the tags (`depth` 0) or to the `]`
/// closing an array (`depth` > 0).
fn arguments(
    reader: &mut Reader<'_>,
    tags: &mut std::str::Bytes<'_>,
    tags_at: usize,
    depth: usize,
) -> Result<Vec<OscType>, Refusal> {
    let mut args = Vec::new();
    loop {
        let Some(tag) = tags.next() else {
            if depth > 0 {
                return refuse(tags_at, "an array `[` without its `]`");
            }
            return Ok(args);
        };
        let arg = match tag {
            b'i' => OscType::Int(reader.int32("an int32 argument")?),
            b'f' => OscType::Float(f32::from_bits(reader.word("a float32 argument")?)),
            b's' | b'S' => OscType::String(reader.string()?.to_owned()),
            b'b' => OscType::Blob(reader.blob()?),
            b'h' => OscType::Long(i64::from_be_bytes(reader.eight("an int64 argument")?)),
            b'd' => OscType::Double(f64::from_bits(u64::from_be_bytes(
                reader.eight("a float64 argument")?,
            ))),
            b't' => {
                let time = reader.eight("a time tag argument")?;
                OscType::Time(OscTime {
                    seconds: u32::from_be_bytes([time[0], time[1], time[2], time[3]]),
                    fractional: u32::from_be_bytes([time[4], time[5], time[6], time[7]]),
                })
            }
            b'c' => {
                let at = reader.at();
                let code = reader.word("a char argument")?;
                match char::from_u32(code) {
                    Some(c) => OscType::Char(c),
                    None => return refuse(at, format!("a char argument of {code:#x}")),
                }
            }
            b'r' => {
                let [red, green, blue, alpha] = reader.word("a colour argument")?.to_be_bytes();
                OscType::Color(OscColor {
                    red,
                    green,
                    blue,
                    alpha,
                })
            }
            b'm' => {
                let [port, status, data1, data2] = reader.word("a MIDI argument")?.to_be_bytes();
                OscType::Midi(OscMidiMessage {
                    port,
                    status,
                    data1,
                    data2,
                })
            }
            b'T' => OscType::Bool(true),
            b'F' => OscType::Bool(false),
            b'N' => OscType::Nil,
            b'I' => OscType::Inf,
            b'[' if depth >= MAX_ARRAY_DEPTH => {
                return refuse(
                    tags_at,
                    format!("arrays nested over {MAX_ARRAY_DEPTH} deep"),
                );
            }
            b'[' => OscType::Array(OscArray {
                content: arguments(reader, tags, tags_at, depth + 1)?,
            }),
            b']' if depth > 0 => return Ok(args),
            b']' => return refuse(tags_at, "a `]` without its `[`"),
            other => {
                return refuse(
                    tags_at,
                    format!("an unknown type tag {:?}", char::from(other)),
                );
            }
        };
        args.push(arg);
    }
}

/// Reads OSC's 4-byte-aligned items from an element, refusing what runs past its end.
struct Reader<'b> {
    bytes: &'b [u8],
    /// The datagram's offset of `bytes[0]`.
    offset: usize,
    /// How far into `bytes` reading is.
    read: usize,
}

impl<'b> Reader<'b> {
    fn new(bytes: &'b [u8], offset: usize) -> Self {
        Self {
            bytes,
            offset,
            read: 0,
        }
    }

    /// The datagram's offset of the next byte.
    fn at(&self) -> usize {
        self.offset + self.read
    }

    fn is_empty(&self) -> bool {
        self.read == self.bytes.len()
    }

    /// The next `count` bytes, `what` naming them in a refusal.
    fn take(&mut self, count: usize, what: &str) -> Result<&'b [u8], Refusal> {
        let Some(taken) = self
            .read
            .checked_add(count)
            .and_then(|end| self.bytes.get(self.read..end))
        else {
            return refuse(self.at(), format!("{what} runs past the end"));
        };
        self.read += count;
        Ok(taken)
    }

    fn word(&mut self, what: &str) -> Result<u32, Refusal> {
        let bytes = self.take(4, what)?;
        Ok(u32::from_be_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]))
    }

    fn int32(&mut self, what: &str) -> Result<i32, Refusal> {
        Ok(self.word(what)?.cast_signed())
    }

    fn eight(&mut self, what: &str) -> Result<[u8; 8], Refusal> {
        let bytes = self.take(8, what)?;
        let mut eight = [0; 8];
        eight.copy_from_slice(bytes);
        Ok(eight)
    }

    /// Skips the padding after `length` bytes of content: NULs up to a multiple of
    /// 4 (`at_least_one`: a string's terminating NUL is one of them).
    fn padding(&mut self, length: usize, at_least_one: bool, what: &str) -> Result<(), Refusal> {
        let padded = if at_least_one {
            (length / 4 + 1) * 4
        } else {
            length.div_ceil(4) * 4
        };
        let at = self.at();
        let pad = self.take(padded - length, what)?;
        if pad.iter().any(|byte| *byte != 0) {
            return refuse(at, format!("{what}: padding that is not all NULs"));
        }
        Ok(())
    }

    /// An OSC-string: UTF-8 up to a NUL, padded with NULs to a multiple of 4.
    fn string(&mut self) -> Result<&'b str, Refusal> {
        let at = self.at();
        let rest = &self.bytes[self.read..];
        let Some(length) = rest.iter().position(|byte| *byte == 0) else {
            return refuse(at, "a string without its terminating NUL");
        };
        let Ok(text) = std::str::from_utf8(&rest[..length]) else {
            return refuse(at, "a string that is not UTF-8");
        };
        self.read += length;
        self.padding(length, true, "a string without its padding")?;
        Ok(text)
    }

    /// An OSC-blob: its size, then as many bytes, padded with NULs to a multiple of 4.
    fn blob(&mut self) -> Result<Vec<u8>, Refusal> {
        let at = self.at();
        let size = self.int32("a blob's size")?;
        let Ok(size) = usize::try_from(size) else {
            return refuse(at, format!("a blob's size of {size}"));
        };
        let content = self.take(size, "a blob")?.to_vec();
        self.padding(size, false, "a blob without its padding")?;
        Ok(content)
    }
}

#[cfg(test)]
mod tests {
    use rosc::{OscBundle, OscPacket};

    use super::*;

    fn osc(addr: &str, args: Vec<OscType>) -> OscPacket {
        OscPacket::Message(OscMessage {
            addr: addr.to_owned(),
            args,
        })
    }

    fn bundle(content: Vec<OscPacket>) -> OscPacket {
        OscPacket::Bundle(OscBundle {
            timetag: (0, 1).into(),
            content,
        })
    }

    fn encode(packet: &OscPacket) -> Vec<u8> {
        rosc::encoder::encode(packet).expect("encodes")
    }

    fn hex(text: &str) -> Vec<u8> {
        (0..text.len())
            .step_by(2)
            .map(|at| u8::from_str_radix(&text[at..at + 2], 16).expect("hex"))
            .collect()
    }

    /// The packet of issue 52: a bundle whose first element is 25 bytes long (not a
    /// multiple of 4), then `/floatball/start 1 -inf`. `rosc` read it as a
    /// `/floatball/start` without arguments: a Start from the beginning.
    const ISSUE_52: &str = "2362756e646c65000000000000000001000000192f666c6f617462616c6c2f7800000000\
                            2c6900000000000100000000202f666c6f617462616c6c2f7374617274000000002c69\
                            660000000001ff800000";

    #[test]
    fn the_misaligned_bundle_of_issue_52_is_refused_whole() {
        let packet = hex(ISSUE_52);
        assert_eq!(packet.len(), 81);
        let refused = decode(&packet).unwrap_err();
        assert!(refused.starts_with("not OSC"), "{refused}");
        // The datagram is 81 bytes: refused before its elements are read. Padded to 84
        // (as a sender might), the 25-byte element is what is refused.
        let mut padded = packet.clone();
        padded.extend([0, 0, 0]);
        let refused = decode(&padded).unwrap_err();
        assert!(refused.contains("size of 25"), "{refused}");
    }

    #[test]
    fn messages_and_bundles_are_read_in_order_with_every_type() {
        let args = vec![
            OscType::Int(-7),
            OscType::Float(0.5),
            OscType::String("abc".into()),
            OscType::Blob(vec![1, 2, 3, 4, 5]),
            OscType::Long(1 << 40),
            OscType::Double(-1.25),
            OscType::Time((3, 4).into()),
            OscType::Char('é'),
            OscType::Color(OscColor {
                red: 1,
                green: 2,
                blue: 3,
                alpha: 4,
            }),
            OscType::Midi(OscMidiMessage {
                port: 1,
                status: 0x90,
                data1: 60,
                data2: 100,
            }),
            OscType::Bool(true),
            OscType::Bool(false),
            OscType::Nil,
            OscType::Inf,
            OscType::Array(OscArray {
                content: vec![
                    OscType::Int(1),
                    OscType::Array(OscArray { content: vec![] }),
                ],
            }),
            OscType::Float(f32::NEG_INFINITY),
        ];
        let message = osc("/floatball/x", args.clone());
        let decoded = decode(&encode(&message)).unwrap();
        assert_eq!(decoded.len(), 1);
        assert_eq!(decoded[0].addr, "/floatball/x");
        assert_eq!(decoded[0].args, args);

        let packet = bundle(vec![
            osc("/floatball/estop", vec![]),
            bundle(vec![
                osc("/floatball/home", vec![]),
                osc("/floatball/goto", vec![OscType::Int(2)]),
            ]),
            osc("/floatball/start", vec![]),
        ]);
        let addrs: Vec<String> = decode(&encode(&packet))
            .unwrap()
            .into_iter()
            .map(|message| message.addr)
            .collect();
        assert_eq!(
            addrs,
            [
                "/floatball/estop",
                "/floatball/home",
                "/floatball/goto",
                "/floatball/start"
            ]
        );
        // An empty bundle is OSC: no messages.
        assert!(decode(&encode(&bundle(vec![]))).unwrap().is_empty());
    }

    /// Each defect of issue 52's list, the whole packet refused, with why.
    #[test]
    fn malformed_packets_are_refused_whole_with_why() {
        let start = encode(&osc(
            "/floatball/start",
            vec![OscType::Int(1), OscType::Float(0.5)],
        ));
        let home = encode(&osc("/floatball/home", vec![]));
        // A bundle of `home` and then `element`, its size as given.
        let bundle_with = |size: u32, element: &[u8]| {
            let mut bytes = b"#bundle\0\0\0\0\0\0\0\0\x01".to_vec();
            bytes.extend(u32::try_from(home.len()).unwrap().to_be_bytes());
            bytes.extend(&home);
            bytes.extend(size.to_be_bytes());
            bytes.extend(element);
            bytes
        };
        let lying_tags = {
            // `/floatball/start ,ifif` with 8 bytes of data.
            let mut bytes = b"/floatball/start\0\0\0\0,ifif\0\0\0".to_vec();
            bytes.extend(1_i32.to_be_bytes());
            bytes.extend(0.5_f32.to_be_bytes());
            bytes
        };
        // `/floatball/ho`, its NUL, and the tags at once (two padding NULs missing).
        let unpadded = b"/floatball/ho\0,\0\0\0\0\0".to_vec();
        let mut nonzero_padding = home.clone();
        nonzero_padding[19] = b'x'; // the type tags `,\0\0\0` → `,\0\0x`
        let mut trailing = home.clone();
        trailing.extend([0, 0, 0, 1]);
        let mut no_tags = b"/floatball/home\0".to_vec();
        no_tags.truncate(16);
        let mut deep = home.clone();
        for _ in 0..=MAX_BUNDLE_DEPTH {
            let mut outer = b"#bundle\0\0\0\0\0\0\0\0\x01".to_vec();
            outer.extend(u32::try_from(deep.len()).unwrap().to_be_bytes());
            outer.extend(&deep);
            deep = outer;
        }
        let mut arrays = b"/floatball/start\0\0\0\0,".to_vec();
        arrays.extend([b'['; MAX_ARRAY_DEPTH + 1]);
        arrays.extend([b']'; MAX_ARRAY_DEPTH + 1]);
        arrays.push(0);
        while !arrays.len().is_multiple_of(4) {
            arrays.push(0);
        }
        let mut start_with_blob = b"/floatball/start\0\0\0\0,b\0\0".to_vec();
        start_with_blob.extend((-4_i32).to_be_bytes());
        for (name, packet, why) in [
            ("a lying type tag", lying_tags.clone(), "runs past the end"),
            (
                "a lying type tag in a bundle",
                bundle_with(u32::try_from(lying_tags.len()).unwrap(), &lying_tags),
                "runs past the end",
            ),
            (
                "an element size not a multiple of 4",
                bundle_with(18, &start[..20]),
                "not a multiple of 4",
            ),
            (
                "an element size past the end",
                bundle_with(64, &start),
                "past the bundle's end",
            ),
            (
                "a negative element size",
                bundle_with(u32::MAX, &start),
                "size of -1",
            ),
            ("an element of 0 bytes", bundle_with(0, &[]), "size of 0"),
            (
                "an element that is neither",
                bundle_with(4, b"abcd"),
                "neither a message",
            ),
            ("a string without padding", unpadded, "without its padding"),
            ("padding that is not NULs", nonzero_padding, "not all NULs"),
            ("data after the arguments", trailing, "after the data"),
            ("no type tag string", no_tags, "without a type tag"),
            ("bundles nested too deep", deep, "nested over"),
            ("arrays nested too deep", arrays, "nested over"),
            ("a negative blob size", start_with_blob, "blob's size of -4"),
            (
                "a datagram of 5 bytes",
                b"/abc\0".to_vec(),
                "not a multiple of 4",
            ),
            ("not OSC", b"hello, w".to_vec(), "neither a message"),
            ("empty", vec![], "empty"),
            (
                "an unknown tag",
                b"/floatball/home\0,x\0\0\0\0\0\0".to_vec(),
                "unknown type tag",
            ),
            (
                "not #bundle",
                b"#bundlX\0\0\0\0\0\0\0\0\x01".to_vec(),
                "does not start `#bundle`",
            ),
            (
                "an unclosed array",
                b"/floatball/home\0,[i\0\0\0\0\x01".to_vec(),
                "without its `]`",
            ),
        ] {
            let refused = decode(&packet).expect_err(name);
            assert!(refused.starts_with("not OSC: "), "{name}: {refused}");
            assert!(refused.contains(why), "{name}: {refused}");
        }
        // Bundles exactly as deep as taken are fine.
        let mut deepest = home.clone();
        for _ in 0..MAX_BUNDLE_DEPTH {
            let mut outer = b"#bundle\0\0\0\0\0\0\0\0\x01".to_vec();
            outer.extend(u32::try_from(deepest.len()).unwrap().to_be_bytes());
            outer.extend(&deepest);
            deepest = outer;
        }
        assert_eq!(decode(&deepest).unwrap().len(), 1);
        assert!(
            decode(&[0; MAX_PACKET_BYTES + 1])
                .unwrap_err()
                .contains("over")
        );
    }

    /// A message's arguments only come from its own bytes: every way of cutting a
    /// bundle of two messages short or long is refused, never read as the second
    /// message without (or with others') arguments.
    #[test]
    fn no_message_takes_another_ones_arguments() {
        let first = encode(&osc("/floatball/x", vec![OscType::Int(1)]));
        let second = encode(&osc(
            "/floatball/start",
            vec![OscType::Int(1), OscType::Float(f32::NEG_INFINITY)],
        ));
        for lie in 1..=first.len() + 8 {
            let mut bytes = b"#bundle\0\0\0\0\0\0\0\0\x01".to_vec();
            bytes.extend(u32::try_from(lie).unwrap().to_be_bytes());
            bytes.extend(&first);
            bytes.extend(u32::try_from(second.len()).unwrap().to_be_bytes());
            bytes.extend(&second);
            match decode(&bytes) {
                Ok(messages) => {
                    assert_eq!(lie, first.len(), "{messages:?}");
                    assert_eq!(messages.len(), 2);
                    assert_eq!(messages[1].args.len(), 2);
                }
                Err(why) => assert!(why.starts_with("not OSC"), "{lie}: {why}"),
            }
        }
    }
}
