//! What each of the bridge's byte readers is sent in the storm, and how each candidate
//! is classified before it goes (`Generator::is_command`): a valid, allowed command is
//! counted and never sent.
//!
//! Every generator mixes four kinds ([`Class`]): random bytes, mutations of valid
//! packets ([`mutate`]: bits flipped, cut short, extended, size fields lying…),
//! structure-aware hostile packets built by hand to be invalid (each with a label
//! the failure's message names), and well-formed input that commands nothing (DMX
//! while live mode is off, an `ArtPoll`, an OSC button's release).
//!
//! - [`Osc`]: OSC from the allowed sender (its classifier is the bridge's own reader,
//!   `floatball_bridge::osc::decode` and `command`: a packet with an e-stop, a Home,
//!   or a Start, Reset or goto the playlist can carry out in it is skipped; the
//!   hand-built cases are sent whatever it says) and from a sender `allow` does not
//!   list (nothing it sends is allowed: it is sent valid commands too).
//! - [`ArtNet`]: Art-Net on the live input's socket (shared with the timecode chase's
//!   on some families); a well-formed ArtTimeCode (`floatball_shared::timecode::artnet`
//!   decodes it) is skipped, since a timecode near the playlist's cue may rightly
//!   start the chase. ArtDmx and ArtPoll are sent as they are: live mode is off, so no
//!   DMX may move a ball.
//! - [`Sacn`]: E1.31 on the live input's socket; all of it is sent (live mode is off).
//! - [`MboxStranger`]: datagrams to the bridge's MBOX host socket from an address that
//!   is no box: all sent (the bridge obeys no one there; it only matches replies).
//! - [`Mtc`]: MIDI bytes into the chase's FIFO, classified in context: a copy of the
//!   bridge's decoder (`MtcDecoder`, fed exactly what was sent) says whether a chunk
//!   would complete a quarter-frame time or a full frame; such a chunk is skipped.

use std::net::Ipv4Addr;

use floatball_bridge::control::Control;
use floatball_shared::live::artnet as live_artnet;
use floatball_shared::live::sacn;
use floatball_shared::mbox::register::FN_ESTOP;
use floatball_shared::mbox::{
    Encode, ReadBank, RegisterBlock, RegisterRange, RegisterRead, RegisterReply, RegisterWrite,
    Route,
};
use floatball_shared::timecode::artnet as tc_artnet;
use floatball_shared::timecode::mtc::{self, MtcDecoder};
use floatball_shared::timecode::{FrameRate, Timecode};

use super::{Class, Draw, Generator, Playable, Rng, mutate};

/// Draws a class: `random`, `mutated`, `crafted` and `input` in these parts per 100.
fn class(rng: &mut Rng, weights: [u64; 4]) -> Class {
    let mut roll = rng.below(weights.iter().sum());
    for (weight, class) in
        weights
            .into_iter()
            .zip([Class::Random, Class::Mutated, Class::Crafted, Class::Input])
    {
        if roll < weight {
            return class;
        }
        roll -= weight;
    }
    Class::Random
}

// ---------------------------------------------------------------- OSC bytes by hand

/// An OSC-string: the bytes, a NUL, NULs to a multiple of 4.
fn osc_string(text: &[u8]) -> Vec<u8> {
    let mut out = text.to_vec();
    out.push(0);
    while !out.len().is_multiple_of(4) {
        out.push(0);
    }
    out
}

/// An OSC argument.
#[derive(Debug, Clone)]
enum Arg {
    I(i32),
    F(f32),
    D(f64),
    H(i64),
    S(&'static str),
    B(Vec<u8>),
    /// A tag with no data: `T`, `F`, `N`, `I`.
    Tag(char),
}

/// A well-formed OSC message.
fn message(address: &str, args: &[Arg]) -> Vec<u8> {
    let mut tags = String::from(",");
    let mut data = Vec::new();
    for arg in args {
        match arg {
            Arg::I(value) => {
                tags.push('i');
                data.extend_from_slice(&value.to_be_bytes());
            }
            Arg::F(value) => {
                tags.push('f');
                data.extend_from_slice(&value.to_be_bytes());
            }
            Arg::D(value) => {
                tags.push('d');
                data.extend_from_slice(&value.to_be_bytes());
            }
            Arg::H(value) => {
                tags.push('h');
                data.extend_from_slice(&value.to_be_bytes());
            }
            Arg::S(text) => {
                tags.push('s');
                data.extend(osc_string(text.as_bytes()));
            }
            Arg::B(blob) => {
                tags.push('b');
                data.extend_from_slice(&u32::try_from(blob.len()).unwrap_or(0).to_be_bytes());
                data.extend_from_slice(blob);
                while !data.len().is_multiple_of(4) {
                    data.push(0);
                }
            }
            Arg::Tag(tag) => tags.push(*tag),
        }
    }
    let mut out = osc_string(address.as_bytes());
    out.extend(osc_string(tags.as_bytes()));
    out.extend(data);
    out
}

/// A message from its address and raw type tags and data (which need not agree).
fn raw_message(address: &[u8], tags: &[u8], data: &[u8]) -> Vec<u8> {
    let mut out = osc_string(address);
    out.extend(osc_string(tags));
    out.extend_from_slice(data);
    out
}

/// A bundle's header: `#bundle`, the time tag "immediately".
fn bundle_header() -> Vec<u8> {
    let mut out = osc_string(b"#bundle");
    out.extend_from_slice(&1u64.to_be_bytes());
    out
}

/// A well-formed bundle of `elements`.
fn bundle(elements: &[Vec<u8>]) -> Vec<u8> {
    let mut out = bundle_header();
    for element in elements {
        out.extend_from_slice(&u32::try_from(element.len()).unwrap_or(0).to_be_bytes());
        out.extend_from_slice(element);
    }
    out
}

/// A bundle whose first element claims `size` bytes (and has them), then `rest`.
fn bundle_with_sized(size: u32, content: &[u8], rest: &[Vec<u8>]) -> Vec<u8> {
    let mut out = bundle_header();
    out.extend_from_slice(&size.to_be_bytes());
    out.extend_from_slice(content);
    for element in rest {
        out.extend_from_slice(&u32::try_from(element.len()).unwrap_or(0).to_be_bytes());
        out.extend_from_slice(element);
    }
    out
}

/// `inner` inside `depth` bundles.
fn nested(depth: usize, inner: Vec<u8>) -> Vec<u8> {
    (0..depth).fold(inner, |packet, _| bundle(&[packet]))
}

fn start() -> Vec<u8> {
    message("/floatball/start", &[])
}

/// The finding of issue 52, byte for byte: a bundle whose first element's size (25) is
/// not a multiple of 4, then `/floatball/start 1 -inf` — which the `rosc` crate read
/// as `/floatball/start` with no arguments, a Start.
pub const FINDING_HEX: &str = "2362756e646c65000000000000000001000000192f666c6f617462616c6c\
2f78000000002c6900000000000100000000202f666c6f617462616c6c2f7374617274000000002c69660000000001\
ff800000";

fn from_hex(text: &str) -> Vec<u8> {
    (0..text.len())
        .step_by(2)
        .map(|at| u8::from_str_radix(&text[at..at + 2], 16).expect("hex"))
        .collect()
}

/// Well-formed commands: the corpus mutations start from (and what a stranger sends).
fn osc_commands() -> Vec<Vec<u8>> {
    vec![
        start(),
        message("/floatball/start", &[Arg::I(1)]),
        message("/floatball/start", &[Arg::I(1), Arg::F(0.5)]),
        message("/floatball/start", &[Arg::F(1.0), Arg::D(0.25)]),
        message("/floatball/reset", &[]),
        message("/floatball/reset", &[Arg::I(1)]),
        message("/floatball/home", &[]),
        message("/floatball/home", &[Arg::I(1)]),
        message("/floatball/goto", &[Arg::I(1)]),
        message("/floatball/estop", &[]),
        message("/floatball/estop", &[Arg::I(1)]),
        bundle(&[start()]),
        bundle(&[message("/floatball/home", &[]), start()]),
        bundle(&[bundle(&[message("/floatball/estop", &[])])]),
    ]
}

/// Structure-aware OSC that no reading of OSC 1.0 and the docs (docs/show-control.md)
/// makes a command the bridge carries out: each invalid by construction. `show_s` is
/// the length of the playlist's only show, seconds.
fn osc_crafted(show_s: f32) -> Vec<(&'static str, Vec<u8>)> {
    let mut cases: Vec<(&'static str, Vec<u8>)> = vec![(
        "bundle: element size 25, then start 1 -inf (issue 52's finding)",
        from_hex(FINDING_HEX),
    )];
    // A valid command hidden behind (or in front of) an element whose size is not a
    // multiple of 4.
    let filler = message("/floatball/x", &[Arg::I(1)]);
    for size in (1u32..=31).filter(|size| !size.is_multiple_of(4)) {
        let mut content = filler.clone();
        content.resize(size as usize, 0);
        cases.push((
            "bundle: element size not a multiple of 4, then a valid start",
            bundle_with_sized(size, &content, &[start()]),
        ));
        cases.push((
            "bundle: element size not a multiple of 4, then start 1 -inf",
            bundle_with_sized(
                size,
                &content,
                &[message(
                    "/floatball/start",
                    &[Arg::I(1), Arg::F(f32::NEG_INFINITY)],
                )],
            ),
        ));
        let mut tail = bundle(&[start()]);
        tail.extend_from_slice(&size.to_be_bytes());
        tail.extend_from_slice(&content);
        cases.push((
            "bundle: a valid start, then an element size not a multiple of 4",
            tail,
        ));
    }
    cases.extend([
        (
            "bundle: element size 0, then a valid start",
            bundle_with_sized(0, &[], &[start()]),
        ),
        (
            "bundle: element size negative, then a valid start",
            bundle_with_sized(u32::MAX, &start(), &[]),
        ),
        ("bundle: element size past its end, a start inside", {
            let mut packet = bundle_header();
            packet.extend_from_slice(&1000u32.to_be_bytes());
            packet.extend(start());
            packet
        }),
        ("bundle: no time tag, a start inside", {
            let mut packet = osc_string(b"#bundle");
            packet.extend_from_slice(&20u32.to_be_bytes());
            packet.extend(start());
            packet
        }),
        ("bundle: #bundle misspelt, a start inside", {
            let mut packet = bundle(&[start()]);
            packet[6] = b'X';
            packet
        }),
        (
            "bundle: an element that is neither message nor bundle, then a start",
            { bundle(&[b"xyz\0".to_vec(), start()]) },
        ),
        (
            "string without its NUL padding: address",
            b"/floatball/start\0,\0\0\0".to_vec(),
        ),
        (
            "string without its NUL: address runs into the type tags",
            b"/floatball/start,\0\0\0".to_vec(),
        ),
        (
            "string without its NUL padding: type tags",
            [
                b"/floatball/start\0\0\0\0,i\0".as_slice(),
                &1i32.to_be_bytes(),
            ]
            .concat(),
        ),
        ("string padded with non-NUL bytes", {
            let mut packet = start();
            packet[17] = b'x';
            packet
        }),
        (
            "type tags that do not match the data: start ,ifif with 8 bytes",
            raw_message(
                b"/floatball/start",
                b",ifif",
                &[1i32.to_be_bytes(), 0.5f32.to_be_bytes()].concat(),
            ),
        ),
        (
            "type tags that do not match the data: ,i with no data",
            raw_message(b"/floatball/start", b",i", &[]),
        ),
        (
            "type tags that do not match the data: ,f with 2 bytes",
            raw_message(b"/floatball/start", b",f", &[0x3f, 0x80]),
        ),
        (
            "type tags that do not match the data: ,s unterminated",
            raw_message(b"/floatball/start", b",s", b"abcd"),
        ),
        (
            "type tags that do not match the data: ,b of 100 bytes with 4",
            raw_message(
                b"/floatball/start",
                b",b",
                &[100u32.to_be_bytes(), [1, 2, 3, 4]].concat(),
            ),
        ),
        (
            "type tags that do not match the data: ,b of negative size",
            raw_message(
                b"/floatball/start",
                b",b",
                &[u32::MAX.to_be_bytes(), [1, 2, 3, 4]].concat(),
            ),
        ),
        (
            "type tags that do not match the data: ,h with 4 bytes",
            raw_message(b"/floatball/start", b",h", &1i32.to_be_bytes()),
        ),
        (
            "type tags that do not match the data: ,d with 4 bytes",
            raw_message(b"/floatball/start", b",d", &1i32.to_be_bytes()),
        ),
        (
            "type tags that do not match the data: ,i with 8 bytes (left over)",
            raw_message(
                b"/floatball/start",
                b",i",
                &[1i32.to_be_bytes(), 1i32.to_be_bytes()].concat(),
            ),
        ),
        (
            "unknown type tag ,x",
            raw_message(b"/floatball/start", b",x", &1i32.to_be_bytes()),
        ),
        (
            "unbalanced array ,[i",
            raw_message(b"/floatball/start", b",[i", &1i32.to_be_bytes()),
        ),
        (
            "array closed twice ,[i]]",
            raw_message(b"/floatball/start", b",[i]]", &1i32.to_be_bytes()),
        ),
        (
            "arrays nested 10 deep",
            raw_message(
                b"/floatball/start",
                b",[[[[[[[[[[i]]]]]]]]]]",
                &1i32.to_be_bytes(),
            ),
        ),
        (
            "a start without a type tag string (pre-1.0)",
            osc_string(b"/floatball/start"),
        ),
        (
            "address not UTF-8",
            raw_message(b"/floatball/st\xffrt", b",", &[]),
        ),
        (
            "nested bundles 100 deep, a start inside (over 1500 bytes)",
            nested(100, start()),
        ),
        (
            "nested bundles 6 deep, a start inside (deeper than 4)",
            nested(6, start()),
        ),
        (
            "over 1500 bytes: a start bundled with a 2 KB blob",
            bundle(&[start(), message("/floatball/x", &[Arg::B(vec![7; 2_000])])]),
        ),
    ]);
    for left_over in 1..=4 {
        let mut packet = start();
        packet.resize(packet.len() + left_over, 0);
        cases.push(("a valid start with bytes left over", packet));
    }
    let mut packet = bundle(&[start()]);
    packet.extend_from_slice(&[0, 0]);
    cases.push(("a bundle with a start and 2 bytes left over", packet));
    // Arguments the docs refuse (well-formed OSC).
    let refused: Vec<(&'static str, &str, Vec<Arg>)> = vec![
        (
            "start 1 -inf",
            "start",
            vec![Arg::I(1), Arg::F(f32::NEG_INFINITY)],
        ),
        (
            "start 1 +inf",
            "start",
            vec![Arg::I(1), Arg::F(f32::INFINITY)],
        ),
        ("start 1 NaN", "start", vec![Arg::I(1), Arg::F(f32::NAN)]),
        ("start 1 -1", "start", vec![Arg::I(1), Arg::F(-1.0)]),
        ("start 1 -0.5", "start", vec![Arg::I(1), Arg::D(-0.5)]),
        (
            "start 1 86400.5",
            "start",
            vec![Arg::I(1), Arg::D(86_400.5)],
        ),
        ("start 1 1e30", "start", vec![Arg::I(1), Arg::F(1e30)]),
        ("start -1", "start", vec![Arg::I(-1)]),
        ("start 1.5", "start", vec![Arg::F(1.5)]),
        ("start 2.5", "start", vec![Arg::F(2.5)]),
        ("start 1e7", "start", vec![Arg::F(1e7)]),
        ("start \"1\"", "start", vec![Arg::S("1")]),
        ("start <blob>", "start", vec![Arg::B(vec![1])]),
        ("start T", "start", vec![Arg::Tag('T')]),
        ("start F", "start", vec![Arg::Tag('F')]),
        ("start N", "start", vec![Arg::Tag('N')]),
        ("start I", "start", vec![Arg::Tag('I')]),
        (
            "start 1 2 3",
            "start",
            vec![Arg::I(1), Arg::I(2), Arg::I(3)],
        ),
        ("start 2^40 (h)", "start", vec![Arg::H(1 << 40)]),
        ("start 1 \"x\"", "start", vec![Arg::I(1), Arg::S("x")]),
        ("goto (none)", "goto", vec![]),
        ("goto 1 2", "goto", vec![Arg::I(1), Arg::I(2)]),
        ("goto \"a\"", "goto", vec![Arg::S("a")]),
        ("goto -3", "goto", vec![Arg::I(-3)]),
        ("goto 1.5", "goto", vec![Arg::F(1.5)]),
        ("home 2", "home", vec![Arg::I(2)]),
        ("home 1 1", "home", vec![Arg::I(1), Arg::I(1)]),
        ("home \"x\"", "home", vec![Arg::S("x")]),
        ("home 0.5", "home", vec![Arg::F(0.5)]),
        (
            "reset 1 -inf",
            "reset",
            vec![Arg::I(1), Arg::F(f32::NEG_INFINITY)],
        ),
        ("reset 1.5", "reset", vec![Arg::F(1.5)]),
        ("reset -1", "reset", vec![Arg::I(-1)]),
        (
            "reset 1 2 3",
            "reset",
            vec![Arg::I(1), Arg::I(2), Arg::I(3)],
        ),
        // Well-formed, at an entry or time the playlist lacks: refused before they
        // change anything (docs/show-control.md, "A refused command changes nothing").
        ("start 2 (no entry 2)", "start", vec![Arg::I(2)]),
        ("start 1000000", "start", vec![Arg::I(1_000_000)]),
        ("start 2 0.5", "start", vec![Arg::I(2), Arg::F(0.5)]),
        (
            "start 1 <the show's end>",
            "start",
            vec![Arg::I(1), Arg::F(show_s)],
        ),
        (
            "start 1 9.995 (past the end)",
            "start",
            vec![Arg::I(1), Arg::F(9.995)],
        ),
        ("start 1 3600", "start", vec![Arg::I(1), Arg::I(3600)]),
        ("reset 2 (no entry 2)", "reset", vec![Arg::I(2)]),
        (
            "reset 1 9.995 (past the end)",
            "reset",
            vec![Arg::I(1), Arg::F(9.995)],
        ),
        (
            "reset 1 <the show's end>",
            "reset",
            vec![Arg::I(1), Arg::F(show_s)],
        ),
        ("goto 2 (no entry 2)", "goto", vec![Arg::I(2)]),
        ("goto 1000000", "goto", vec![Arg::I(1_000_000)]),
    ];
    for (label, command, args) in refused {
        cases.push((label, message(&format!("/floatball/{command}"), &args)));
    }
    for address in [
        "/floatball/jump",
        "/floatball/start/",
        "/FLOATBALL/START",
        "/floatball/startx",
        "//floatball/start",
        "/floatball",
        "/",
        "/floatball/stop",
        "/floatball/play",
    ] {
        cases.push(("unknown address", message(address, &[Arg::I(1)])));
    }
    cases.push((
        "no leading slash",
        raw_message(b"floatball/start", b",", &[]),
    ));
    cases.push(("empty address", raw_message(b"", b",", &[])));
    cases.extend([
        (
            "feedback address: state",
            message("/floatball/state", &[Arg::S("playing")]),
        ),
        (
            "feedback address: latched",
            message("/floatball/latched", &[Arg::I(1)]),
        ),
        (
            "feedback address: refused",
            message(
                "/floatball/refused",
                &[Arg::S("/floatball/start"), Arg::S("x")],
            ),
        ),
    ]);
    cases
}

/// Well-formed OSC that commands nothing: a button's release (one argument 0).
fn osc_inputs() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        (
            "release: start 0",
            message("/floatball/start", &[Arg::I(0)]),
        ),
        (
            "release: start 0.0",
            message("/floatball/start", &[Arg::F(0.0)]),
        ),
        ("release: home 0", message("/floatball/home", &[Arg::I(0)])),
        ("release: goto 0", message("/floatball/goto", &[Arg::I(0)])),
        (
            "release: reset 0",
            message("/floatball/reset", &[Arg::I(0)]),
        ),
        (
            "release: a bundle of releases",
            bundle(&[
                message("/floatball/start", &[Arg::I(0)]),
                message("/floatball/home", &[Arg::F(0.0)]),
            ]),
        ),
    ]
}

/// OSC from one sender: the allowed one, or one `allow` does not list.
#[derive(Debug)]
pub struct Osc {
    allowed: bool,
    playable: Playable,
    corpus: Vec<Vec<u8>>,
    crafted: Vec<(&'static str, Vec<u8>)>,
    inputs: Vec<(&'static str, Vec<u8>)>,
}

impl Osc {
    /// For the sender `allow` lists, with what the playlist can play.
    pub fn allowed(playable: Playable) -> Self {
        let show_s = playable.show_ms as f32 / 1000.0;
        Self {
            allowed: true,
            playable,
            corpus: osc_commands(),
            crafted: osc_crafted(show_s),
            inputs: osc_inputs(),
        }
    }

    /// For a sender `allow` does not list: valid commands are crafted inputs too.
    pub fn stranger(playable: Playable) -> Self {
        let show_s = playable.show_ms as f32 / 1000.0;
        let mut crafted = osc_crafted(show_s);
        crafted.extend(
            osc_commands()
                .into_iter()
                .map(|command| ("a valid command from a stranger", command)),
        );
        Self {
            allowed: false,
            playable,
            corpus: osc_commands(),
            crafted,
            inputs: osc_inputs(),
        }
    }
}

impl Generator for Osc {
    fn draw(&mut self, rng: &mut Rng) -> Draw {
        match class(rng, [20, 35, 35, 10]) {
            Class::Random => {
                let len = rng.datagram_len();
                let mut bytes = match rng.below(3) {
                    0 => b"/floatball/".to_vec(),
                    1 => bundle_header(),
                    _ => Vec::new(),
                };
                bytes.extend(rng.bytes(len));
                if rng.chance(500) {
                    bytes.truncate(bytes.len() / 4 * 4);
                }
                Draw::new(Class::Random, "random bytes", bytes)
            }
            Class::Mutated => {
                let base = rng.pick(&self.corpus).clone();
                Draw::new(Class::Mutated, "a valid packet mutated", mutate(rng, &base))
            }
            Class::Crafted => {
                let (label, bytes) = rng.pick(&self.crafted).clone();
                Draw::new(Class::Crafted, label, bytes)
            }
            Class::Input => {
                let (label, bytes) = rng.pick(&self.inputs).clone();
                Draw::new(Class::Input, label, bytes)
            }
        }
    }

    fn is_command(&mut self, draw: &Draw) -> bool {
        if !self.allowed {
            return false;
        }
        let Ok(messages) = floatball_bridge::osc::decode(&draw.bytes) else {
            return false;
        };
        messages
            .iter()
            .any(|message| match floatball_bridge::osc::command(message) {
                Ok(floatball_bridge::osc::Command::Estop) => true,
                Ok(floatball_bridge::osc::Command::Control(control)) => match control {
                    Control::Start(from) | Control::Reset(from) => self.playable.plays(from),
                    // Home, and anything else that moves.
                    _ => true,
                },
                Ok(floatball_bridge::osc::Command::Release) | Err(_) => false,
            })
    }
}

// ---------------------------------------------------------------- Art-Net

/// An ArtTimeCode near the playlist's cue (10:00:00:00 at 25 fps).
fn timecode_packet(rng: &mut Rng) -> Vec<u8> {
    let ms = 10 * 3_600_000 - 5_000 + rng.below(20_000);
    tc_artnet::encode(Timecode::from_ms(ms, FrameRate::Ebu25)).to_vec()
}

/// An ArtDmx for universe 1 (the patch's) with `slots` random slots.
fn dmx(rng: &mut Rng, universe: u16, slots: usize) -> Vec<u8> {
    let address = live_artnet::PortAddress::of_universe(universe).expect("a universe");
    let data = rng.bytes(slots);
    live_artnet::encode_dmx(rng.byte(), address, &data)
}

/// Art-Net into the live input's socket (and the chase's, where they are one or
/// where the chase has its own: each destination in turn).
#[derive(Debug, Default)]
pub struct ArtNet;

impl ArtNet {
    fn crafted(rng: &mut Rng) -> Draw {
        let timecode = timecode_packet(rng);
        let (label, bytes): (&'static str, Vec<u8>) = match rng.below(16) {
            0 => {
                let mut bytes = timecode;
                let at = rng.index(8);
                bytes[at] ^= 0x20;
                ("wrong ID", bytes)
            }
            1 => ("ID only", live_artnet::ID.to_vec()),
            2 => ("ID without its NUL", b"Art-Net".to_vec()),
            3 => {
                let mut bytes = timecode;
                let opcode: u16 =
                    *rng.pick(&[0x0097, 0x9701, 0x9600, 0x0050, 0xFFFF, 0, 0x5100, 0x5200]);
                bytes[8..10].copy_from_slice(&opcode.to_le_bytes());
                ("wrong OpCode (a timecode's body)", bytes)
            }
            4 => {
                let mut bytes = timecode;
                bytes.truncate(10 + rng.index(9));
                ("short ArtTimeCode", bytes)
            }
            5 => {
                let mut bytes = timecode;
                bytes[10..12]
                    .copy_from_slice(&u16::try_from(rng.below(14)).unwrap_or(0).to_be_bytes());
                ("ArtTimeCode of ProtVer below 14", bytes)
            }
            6 => {
                let mut bytes = timecode;
                match rng.below(6) {
                    0 => bytes[14] = 25,
                    1 => bytes[15] = 60,
                    2 => bytes[16] = 60,
                    3 => bytes[17] = 24,
                    4 => bytes[18] = 4 + rng.byte() % 252,
                    _ => {
                        bytes[18] = 0;
                        bytes[14] = 24;
                    }
                }
                ("ArtTimeCode out of range", bytes)
            }
            7 => {
                let mut bytes = dmx(rng, 1, 6);
                bytes.truncate(rng.index(18));
                ("short ArtDmx", bytes)
            }
            8 => {
                let mut bytes = dmx(rng, 1, 6);
                let lie: u16 = *rng.pick(&[0, 1, 3, 512, 513, 600, 0xFFFF]);
                bytes[16..18].copy_from_slice(&lie.to_be_bytes());
                ("ArtDmx whose length lies", bytes)
            }
            9 => {
                let mut bytes = dmx(rng, 1, 20);
                bytes[16..18].copy_from_slice(&2u16.to_be_bytes());
                ("ArtDmx longer than its length", bytes)
            }
            10 => {
                let mut bytes = dmx(rng, 1, 6);
                bytes[14..16].copy_from_slice(&0x7FFFu16.to_le_bytes());
                ("ArtDmx for an unpatched universe", bytes)
            }
            11 => {
                let mut bytes = dmx(rng, 1, 6);
                bytes[10..12].copy_from_slice(&0u16.to_be_bytes());
                ("ArtDmx of ProtVer 0", bytes)
            }
            12 => {
                let mut bytes = dmx(rng, 1, 514);
                bytes[16..18].copy_from_slice(&514u16.to_be_bytes());
                ("ArtDmx of 514 slots", bytes)
            }
            13 => {
                let mut bytes = live_artnet::encode_poll(live_artnet::ArtPoll {
                    flags: 0,
                    diag_priority: 0,
                });
                bytes.truncate(11);
                ("short ArtPoll", bytes)
            }
            14 => {
                let mut bytes = live_artnet::ID.to_vec();
                bytes.extend_from_slice(&live_artnet::OP_POLL_REPLY.to_le_bytes());
                bytes.extend(rng.bytes(229));
                ("an ArtPollReply from outside", bytes)
            }
            _ => {
                let mut bytes = live_artnet::ID.to_vec();
                bytes.extend_from_slice(&tc_artnet::OP_TIME_CODE.to_le_bytes());
                bytes.extend({
                    let len = rng.index(40);
                    rng.bytes(len)
                });
                ("ArtTimeCode of random fields", bytes)
            }
        };
        Draw::new(Class::Crafted, label, bytes)
    }
}

impl Generator for ArtNet {
    fn draw(&mut self, rng: &mut Rng) -> Draw {
        match class(rng, [20, 35, 30, 15]) {
            Class::Random => {
                let len = rng.datagram_len();
                let mut bytes = if rng.chance(500) {
                    live_artnet::ID.to_vec()
                } else {
                    Vec::new()
                };
                bytes.extend(rng.bytes(len));
                Draw::new(Class::Random, "random bytes", bytes)
            }
            Class::Mutated => {
                let base = match rng.below(3) {
                    0 => timecode_packet(rng),
                    1 => dmx(rng, 1, 6),
                    _ => live_artnet::encode_poll(live_artnet::ArtPoll {
                        flags: 2,
                        diag_priority: 0,
                    }),
                };
                Draw::new(Class::Mutated, "a valid packet mutated", mutate(rng, &base))
            }
            Class::Crafted => Self::crafted(rng),
            Class::Input => {
                if rng.chance(50) {
                    let poll = live_artnet::encode_poll(live_artnet::ArtPoll {
                        flags: 0,
                        diag_priority: 0,
                    });
                    Draw::new(Class::Input, "ArtPoll", poll)
                } else {
                    let slots = 2 * (1 + rng.index(256));
                    Draw::new(Class::Input, "ArtDmx (live mode off)", dmx(rng, 1, slots))
                }
            }
        }
    }

    fn is_command(&mut self, draw: &Draw) -> bool {
        matches!(
            tc_artnet::decode(&draw.bytes),
            Ok(tc_artnet::Packet::TimeCode { .. })
        )
    }

    /// "ArtTimeCode of random fields" may happen to be a valid one: every candidate
    /// is classified, crafted ones too.
    fn crafted_overrides(&self) -> bool {
        false
    }
}

// ---------------------------------------------------------------- sACN

/// A valid E1.31 data packet for `universe`.
fn sacn_data(rng: &mut Rng, universe: u16, sequence: u8, priority: u8, slots: usize) -> Vec<u8> {
    let data = rng.bytes(slots);
    sacn::encode_data(&sacn::DataPacket {
        cid: *b"floatball-storm!",
        source_name: b"floatball storm",
        priority,
        sync_address: 0,
        sequence,
        options: sacn::Options::default(),
        universe,
        start_code: 0,
        data: &data,
    })
}

/// E1.31 into the live input's socket.
#[derive(Debug, Default)]
pub struct Sacn {
    sequence: u8,
}

impl Sacn {
    fn crafted(&mut self, rng: &mut Rng) -> Draw {
        self.sequence = self.sequence.wrapping_add(1);
        let mut bytes = sacn_data(rng, 1, self.sequence, 100, 6);
        let set16 = |bytes: &mut Vec<u8>, at: usize, value: u16| {
            bytes[at..at + 2].copy_from_slice(&value.to_be_bytes());
        };
        let label = match rng.below(20) {
            0 => {
                let priority = 201 + rng.byte() % 55;
                bytes = sacn_data(rng, 1, self.sequence, priority, 6);
                "priority over 200"
            }
            1 => {
                let universe = *rng.pick(&[0u16, 64_000, 65_535, 7]);
                bytes = sacn_data(rng, universe, self.sequence, 100, 6);
                "wrong universe"
            }
            2 => {
                set16(&mut bytes, 0, 0x0011);
                "preamble size wrong"
            }
            3 => {
                set16(&mut bytes, 2, 0x0001);
                "postamble size not 0"
            }
            4 => {
                bytes[4 + rng.index(12)] ^= 0x40;
                "ACN packet identifier wrong"
            }
            5 => {
                bytes[18..22].copy_from_slice(&[0, 0, 0, *rng.pick(&[0, 3, 5, 9])]);
                "bad root vector"
            }
            6 => {
                let lie = 0x7000 | u16::try_from(rng.below(0x1000)).unwrap_or(0);
                set16(&mut bytes, 16, lie);
                "root length lies"
            }
            7 => {
                bytes[40..44].copy_from_slice(&[0, 0, 0, *rng.pick(&[0, 1, 3, 4])]);
                "bad framing vector"
            }
            8 => {
                let lie = 0x7000 | u16::try_from(rng.below(0x1000)).unwrap_or(0);
                set16(&mut bytes, 38, lie);
                "framing length lies"
            }
            9 => {
                bytes[117] = *rng.pick(&[0, 1, 3, 0xFF]);
                "bad DMP vector"
            }
            10 => {
                bytes[118] = *rng.pick(&[0, 0xA0, 0xA2, 0xFF]);
                "bad DMP address type"
            }
            11 => {
                set16(&mut bytes, 119, 1);
                "DMP first address not 0"
            }
            12 => {
                set16(&mut bytes, 121, 0);
                "DMP increment not 1"
            }
            13 => {
                let lie = *rng.pick(&[0u16, 514, 600, 0xFFFF, 3]);
                set16(&mut bytes, 123, lie);
                "DMP property count lies"
            }
            14 => {
                let lie = 0x7000 | u16::try_from(rng.below(0x1000)).unwrap_or(0);
                set16(&mut bytes, 115, lie);
                "DMP length lies"
            }
            15 => {
                bytes[125] = *rng.pick(&[0xDD, 0x17, 0xCC, 0xFF]);
                "another start code"
            }
            16 => {
                let cut = *rng.pick(&[0usize, 16, 37, 38, 100, 114, 115, 124, 125]);
                bytes.truncate(cut);
                "cut short at a layer's edge"
            }
            17 => {
                bytes[112] = sacn::OPTION_PREVIEW;
                "preview data"
            }
            18 => {
                bytes = sacn::encode_discovery(*b"floatball-storm!", &[1, 2, 3]);
                let at = 4 + rng.index(bytes.len() - 4);
                bytes[at] ^= 0xFF;
                "a discovery packet damaged"
            }
            _ => {
                // A synchronisation packet (extended root vector) cut or padded.
                bytes[18..22].copy_from_slice(&sacn::VECTOR_ROOT_E131_EXTENDED.to_be_bytes());
                bytes[40..44]
                    .copy_from_slice(&sacn::VECTOR_E131_EXTENDED_SYNCHRONIZATION.to_be_bytes());
                bytes.truncate(49 + rng.index(20));
                "a synchronisation packet damaged"
            }
        };
        Draw::new(Class::Crafted, label, bytes)
    }
}

impl Generator for Sacn {
    fn draw(&mut self, rng: &mut Rng) -> Draw {
        match class(rng, [20, 35, 30, 15]) {
            Class::Random => {
                let len = rng.datagram_len();
                let mut bytes = if rng.chance(500) {
                    let mut head = vec![0x00, 0x10, 0x00, 0x00];
                    head.extend_from_slice(&sacn::ACN_PACKET_IDENTIFIER);
                    head
                } else {
                    Vec::new()
                };
                bytes.extend(rng.bytes(len));
                Draw::new(Class::Random, "random bytes", bytes)
            }
            Class::Mutated => {
                self.sequence = self.sequence.wrapping_add(1);
                let base = if rng.chance(800) {
                    sacn_data(rng, 1, self.sequence, 100, 6)
                } else {
                    sacn::encode_discovery(*b"floatball-storm!", &[1])
                };
                Draw::new(Class::Mutated, "a valid packet mutated", mutate(rng, &base))
            }
            Class::Crafted => self.crafted(rng),
            Class::Input => {
                self.sequence = self.sequence.wrapping_add(1);
                let slots = 1 + rng.index(512);
                let bytes = sacn_data(rng, 1, self.sequence, 100, slots);
                Draw::new(Class::Input, "E1.31 data (live mode off)", bytes)
            }
        }
    }

    fn is_command(&mut self, _draw: &Draw) -> bool {
        false
    }
}

// ---------------------------------------------------------------- MBOX host socket

/// Datagrams to the bridge's MBOX host socket from an address that is no box.
#[derive(Debug, Default)]
pub struct MboxStranger;

/// Valid MBOX datagrams: a poll, the answers a box gives it (e-stop set and clear),
/// the e-stop write and its release.
fn mbox_corpus() -> Vec<Vec<u8>> {
    let reply = |value: u16| {
        RegisterReply {
            bank: ReadBank::Fn,
            route: Route::REPLY,
            block: RegisterBlock::new(FN_ESTOP, vec![value]).expect("a block"),
        }
        .encode()
    };
    vec![
        RegisterRead {
            bank: ReadBank::Fn,
            route: Route::BROADCAST,
            range: RegisterRange::new(FN_ESTOP, 1).expect("a range"),
        }
        .encode(),
        reply(1),
        reply(0),
        RegisterWrite::estop(Route::BROADCAST).encode(),
        RegisterWrite::release_estop(Route::BROADCAST).encode(),
    ]
}

impl Generator for MboxStranger {
    fn draw(&mut self, rng: &mut Rng) -> Draw {
        let corpus = mbox_corpus();
        match class(rng, [30, 40, 30, 0]) {
            Class::Random => {
                let len = rng.datagram_len();
                Draw::new(Class::Random, "random bytes", rng.bytes(len))
            }
            Class::Mutated => {
                let base = rng.pick(&corpus).clone();
                Draw::new(
                    Class::Mutated,
                    "a valid datagram mutated",
                    mutate(rng, &base),
                )
            }
            _ => {
                let index = rng.index(corpus.len());
                let label = match index {
                    0 => "a poll, from a stranger",
                    1 => "a reply saying the e-stop is set, from a stranger",
                    2 => "a reply saying the e-stop is clear, from a stranger",
                    3 => "the e-stop write, from a stranger",
                    _ => "the e-stop's release, from a stranger",
                };
                let mut bytes = corpus[index].clone();
                if rng.chance(300) {
                    let keep = rng.index(bytes.len());
                    bytes.truncate(keep);
                }
                Draw::new(Class::Crafted, label, bytes)
            }
        }
    }

    fn is_command(&mut self, _draw: &Draw) -> bool {
        false
    }
}

// ---------------------------------------------------------------- MTC

/// MIDI timecode bytes, classified in context by a copy of the bridge's decoder.
#[derive(Debug, Default)]
pub struct Mtc {
    /// The bridge's decoder as it stands after everything sent so far.
    mirror: MtcDecoder,
}

impl Mtc {
    fn quarter_frames(rng: &mut Rng) -> [u8; 16] {
        let ms = 10 * 3_600_000 - 5_000 + rng.below(20_000);
        mtc::quarter_frames(Timecode::from_ms(ms, FrameRate::Ebu25))
    }

    fn full_frame(rng: &mut Rng) -> [u8; 10] {
        let ms = 10 * 3_600_000 - 5_000 + rng.below(20_000);
        mtc::full_frame_message(Timecode::from_ms(ms, FrameRate::Ebu25))
    }

    fn crafted(rng: &mut Rng) -> Draw {
        let pieces = Self::quarter_frames(rng);
        let full = Self::full_frame(rng);
        let (label, bytes): (&'static str, Vec<u8>) = match rng.below(11) {
            0 => {
                let mut pairs: Vec<[u8; 2]> = pieces.chunks(2).map(|p| [p[0], p[1]]).collect();
                for at in (1..pairs.len()).rev() {
                    let other = rng.index(at + 1);
                    pairs.swap(at, other);
                }
                ("quarter frames out of order", pairs.concat())
            }
            1 => {
                let mut bytes = pieces[..14].to_vec();
                bytes.extend_from_slice(&[0x90, 0x40, 0x7F]);
                ("seven quarter frames, then a note", bytes)
            }
            2 => {
                let mut bytes = pieces.to_vec();
                let at = 1 + 2 * rng.index(8);
                bytes[at] |= 0x80;
                ("a quarter frame's data byte with bit 7 set", bytes)
            }
            3 => ("F1 followed by a status byte", vec![0xF1, 0xF1, 0xF2, 0x00]),
            4 => {
                let mut bytes = full.to_vec();
                bytes[4] = 0x02;
                ("full frame with the wrong sub-ID", bytes)
            }
            5 => {
                let mut bytes = full.to_vec();
                bytes[5] = (bytes[5] & 0x60) | 0x19;
                ("full frame at hour 25", bytes)
            }
            6 => {
                let mut bytes = full.to_vec();
                bytes[8] = 0x7F;
                ("full frame at frame 127", bytes)
            }
            7 => {
                let mut bytes = full[..9].to_vec();
                bytes.push(0x90);
                ("full frame without its F7", bytes)
            }
            8 => {
                let mut bytes = vec![0xF0];
                bytes.extend((0..1_000).map(|_| rng.byte() & 0x7F));
                bytes.push(0xF7);
                ("a SysEx of 1000 bytes", bytes)
            }
            9 => {
                let mut bytes = full.to_vec();
                bytes.insert(5, 0x00);
                ("full frame one byte too long", bytes)
            }
            _ => (
                "running status noise",
                vec![0x90, 0x40, 0x7F, 0x41, 0x7F, 0x80],
            ),
        };
        Draw::new(Class::Crafted, label, bytes)
    }
}

impl Generator for Mtc {
    fn draw(&mut self, rng: &mut Rng) -> Draw {
        match class(rng, [30, 35, 30, 5]) {
            Class::Random => {
                let len = 1 + rng.index(32);
                Draw::new(Class::Random, "random bytes", rng.bytes(len))
            }
            Class::Mutated => {
                let base = if rng.chance(700) {
                    Self::quarter_frames(rng).to_vec()
                } else {
                    Self::full_frame(rng).to_vec()
                };
                Draw::new(Class::Mutated, "valid MTC mutated", mutate(rng, &base))
            }
            Class::Crafted => Self::crafted(rng),
            Class::Input => {
                let len = 1 + rng.index(8);
                let bytes = (0..len).map(|_| 0xF8 + rng.byte() % 8).collect();
                Draw::new(Class::Input, "real-time bytes", bytes)
            }
        }
    }

    fn is_command(&mut self, draw: &Draw) -> bool {
        let mut trial = self.mirror.clone();
        if trial.push_all(&draw.bytes).is_empty() {
            self.mirror = trial;
            false
        } else {
            true
        }
    }

    fn crafted_overrides(&self) -> bool {
        false
    }
}

/// The loopback address a stranger sends from (`allow` lists only 127.0.0.1).
pub const STRANGER: Ipv4Addr = Ipv4Addr::new(127, 0, 0, 2);
