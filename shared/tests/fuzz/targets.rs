//! Fuzz targets for every reader of untrusted bytes: the gateway's streaming
//! instruction reader, the simulated gateway behind its serial line, the bridge's
//! feedback decoder, its console parser, the MBOX datagram decoder, the MBOX console's
//! parser, the SCL parsers (MOONS' drives: command lines, answers, eSCL datagrams),
//! and live input's Art-Net and sACN decoders and the merge they feed.
//!
//! Each target takes a seed and a number of bytes, makes a reproducible stream of
//! line noise ([`LineNoise`]: binary chunks and instruction fragments) mixed with
//! valid input, feeds it in random chunks and checks its properties as it goes; a
//! failed property panics with the seed and the offset. The same targets run briefly
//! in `cargo test -p floatball-shared --test fuzz` and at length in
//! `cargo bench -p floatball-shared --bench fuzz -- --bytes N` (`cargo xtask fuzz`).
#![allow(dead_code)] // Each harness uses its own part of this.

use std::collections::BTreeSet;

use floatball_shared::live::artnet::{self, ArtNetError, PortAddress};
use floatball_shared::live::merge::{Fed, MAX_SOURCES, Merge};
use floatball_shared::live::sacn::{self, SacnError};
use floatball_shared::mbox::console::{self as mbox_console, ConsoleErrorKind};
use floatball_shared::mbox::{
    AxisCount, AxisPositions, BoxAddress, Datagram, DecodeError, DigitalOutputs, Encode,
    MotionFrame, ReadBank, RegisterBlock, RegisterRange, RegisterRead, RegisterReply,
    RegisterWrite, Route, TimeCode, TimeMode, WriteBank,
};
use floatball_shared::scl;
use floatball_shared::scl::twin::{Bus, Drive, DriveConfig, StartWire};
use floatball_shared::scl::{Address, IoPoint, Reply, Request};
use floatball_shared::uim2503::ascii::{Form, Instruction, InstructionReader, parse_script};
use floatball_shared::uim2503::feedback::{Ack, Feedback, Frame, FrameDecoder, MAX_FRAME_LEN};
use floatball_shared::uim2503::sim::noise::{LineNoise, SplitMix};
use floatball_shared::uim2503::sim::{GatewayConfig, TX_QUEUE_BYTES, Uart};

/// What one run of a target did.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// Bytes fed.
    pub bytes: u64,
    /// Named counts, in a fixed order.
    pub counts: Vec<(&'static str, u64)>,
}

impl Report {
    fn count(&mut self, name: &'static str, by: u64) {
        match self.counts.iter_mut().find(|(n, _)| *n == name) {
            Some((_, count)) => *count += by,
            None => self.counts.push((name, by)),
        }
    }

    /// Adds `other` to this report.
    pub fn absorb(&mut self, other: &Report) {
        self.bytes += other.bytes;
        for &(name, count) in &other.counts {
            self.count(name, count);
        }
    }
}

/// A target: seed and byte budget in, report out.
pub type Target = fn(u64, usize) -> Report;

/// Every target, by name.
pub const TARGETS: [(&str, Target); 11] = [
    ("reader", reader),
    ("gateway", gateway),
    ("decoder", decoder),
    ("console", console),
    ("mbox", mbox),
    ("mbox-console", mbox_console),
    ("scl", scl),
    ("scl-twin", scl_twin),
    ("artnet", artnet),
    ("sacn", sacn),
    ("live-merge", live_merge),
];

/// The roll call the liveness property sends after the noise: end whatever
/// instruction the noise left open, stop every unit, ask every unit its serial.
const ROLL_CALL: &[u8] = b";;;*0;MO=0;*0;SN;";

/// The streaming instruction reader: chunked and byte-by-byte reading agree; after
/// any noise and a `;`, valid instructions are read exactly.
pub fn reader(seed: u64, bytes: usize) -> Report {
    let mut noise = LineNoise::new(seed);
    let mut chunked = InstructionReader::new();
    let mut bytewise = InstructionReader::new();
    let mut report = Report::default();
    let mut chunk = Vec::new();
    let mut results = Vec::new();
    let probe = b"*7;QP[3]=-1000;  mo = 1 ;";
    let expected = parse_script("*7;QP[3]=-1000;MO=1;").expect("the probe parses");
    while (report.bytes as usize) < bytes {
        chunk.clear();
        noise.chunk(&mut chunk);
        if noise.rng().below(4) == 0 {
            // A long run without `;`: the reader counts it and holds 20 bytes.
            let run = noise.rng().below(5000) as usize;
            chunk.extend(std::iter::repeat_n(b'7', run));
        }
        let probing = noise.rng().below(8) == 0;
        let closed_at = chunk.len();
        if probing {
            chunk.push(b';');
            chunk.extend_from_slice(probe);
        }
        results.clear();
        let mut rest = &chunk[..];
        while !rest.is_empty() {
            let cut = 1 + noise.rng().below(rest.len() as u64) as usize;
            let (piece, after) = rest.split_at(cut);
            results.extend(chunked.push(piece));
            rest = after;
        }
        let mut by_byte = chunk.iter().filter_map(|&byte| bytewise.push_byte(byte));
        for (i, result) in results.iter().enumerate() {
            assert_eq!(
                Some(result),
                by_byte.next().as_ref(),
                "seed {seed}, byte {}: result {i} differs by chunking",
                report.bytes
            );
        }
        assert!(by_byte.next().is_none(), "seed {seed}: bytewise read more");
        assert_eq!(chunked.pending(), bytewise.pending());
        if probing {
            let tail = &results[results.len() - expected.len()..];
            let read: Vec<_> = tail.iter().filter_map(|r| r.ok()).collect();
            assert_eq!(
                read, expected,
                "seed {seed}, byte {}: the probe after {closed_at} bytes of noise",
                report.bytes
            );
            assert_eq!(chunked.pending(), 0);
            report.count("probes", 1);
        }
        let ok = results.iter().filter(|r| r.is_ok()).count() as u64;
        report.count("instructions", ok);
        report.count("errors", results.len() as u64 - ok);
        report.bytes += chunk.len() as u64;
    }
    report
}

/// The simulated gateway behind its serial line: noise at any speed (bursts far beyond
/// the line, pauses that let moves and rows run); the answers always decode, the queue
/// stays bounded, and — the liveness property — after any noise, `;` and a roll call
/// sent at the line's speed, every unit answers with its serial number within the time
/// the line needs for a full queue and the answers.
pub fn gateway(seed: u64, bytes: usize) -> Report {
    let mut noise = LineNoise::new(seed);
    let (config, baud) = match seed % 4 {
        0 => (GatewayConfig::numbered(100), 921_600),
        1 => (GatewayConfig::numbered(100), 115_200),
        2 => (GatewayConfig::factory_fresh(8), 9600),
        _ => (GatewayConfig::numbered(17), 460_800),
    };
    let mut uart = Uart::new(config, baud).expect("a valid configuration");
    let travel = 750_000.0;
    let serials: BTreeSet<u64> = uart.gateway().units().map(|unit| unit.serial).collect();
    let units = serials.len();
    // One byte on the line, µs (rounded up).
    let byte_us = |count: usize| (count as u64 * 10_000_000).div_ceil(u64::from(baud));
    let mut decoder = FrameDecoder::new();
    let mut report = Report::default();
    let mut chunk = Vec::new();
    let mut out = Vec::new();
    let mut frames: Vec<Frame> = Vec::new();
    let mut now_us: u64 = 0;
    let mut next_probe = 1 + noise.rng().below(64 * 1024) as usize;
    while (report.bytes as usize) < bytes {
        chunk.clear();
        noise.chunk(&mut chunk);
        now_us += match noise.rng().below(8) {
            // A burst: no time at all, or far faster than the line.
            0 | 1 => 0,
            2 => byte_us(chunk.len()) / 10,
            // At the line's speed, or slower.
            3..=5 => byte_us(chunk.len()),
            6 => byte_us(chunk.len()) * 3,
            // A pause: moves, rows and timed starts run.
            _ => noise.rng().below(2_000_000),
        };
        uart.receive(now_us, &chunk);
        report.bytes += chunk.len() as u64;
        out.clear();
        uart.step(now_us, &mut out);
        frames.clear();
        frames.extend(decoder.push(&out));
        assert!(
            uart.queued_bytes() <= TX_QUEUE_BYTES + MAX_FRAME_LEN,
            "seed {seed}: {} bytes queued",
            uart.queued_bytes()
        );
        // A roll call every 32 kB or so, and at the end.
        if (report.bytes as usize) < next_probe.min(bytes) {
            continue;
        }
        next_probe += 1 + noise.rng().below(64 * 1024) as usize;
        // The roll call, sent at the line's speed after the noise.
        now_us += byte_us(ROLL_CALL.len() + 1);
        assert!(
            uart.room(now_us) >= ROLL_CALL.len(),
            "seed {seed}: the line has no room"
        );
        let overrun = uart.stats().overrun_bytes;
        uart.receive(now_us, ROLL_CALL);
        assert_eq!(uart.stats().overrun_bytes, overrun);
        report.bytes += ROLL_CALL.len() as u64;
        // The line needs: a full queue, the frame on the wire, and the answers.
        let answers = 3 * 5 + units * 12;
        let deadline = now_us + byte_us(TX_QUEUE_BYTES + MAX_FRAME_LEN + answers) + 1;
        out.clear();
        uart.step(deadline, &mut out);
        now_us = deadline;
        frames.clear();
        frames.extend(decoder.push(&out));
        assert_eq!(uart.queued_bytes(), 0, "seed {seed}: answers still queued");
        assert_eq!(decoder.pending(), 0, "seed {seed}: half a frame");
        let answered: BTreeSet<u64> = frames
            .iter()
            .rev()
            .take(units)
            .filter_map(|frame| match Feedback::from_frame(frame) {
                Ok(Feedback::Ack(Ack::Serial { serial })) => Some(serial),
                _ => None,
            })
            .collect();
        assert_eq!(
            answered, serials,
            "seed {seed}, byte {}: the roll call was not answered by every unit",
            report.bytes
        );
        assert_eq!(
            uart.gateway().next_event_us(),
            None,
            "seed {seed}: something still runs after MO=0"
        );
        for unit in uart.gateway().units() {
            assert!(!unit.moving && !unit.motor_on, "seed {seed}: {unit:?}");
            assert!((0.0..=travel).contains(&unit.position_counts), "{unit:?}");
        }
        report.count("roll calls", 1);
    }
    let stats = uart.stats();
    let decoded = decoder.stats();
    assert_eq!(
        decoded.dropped_bytes, 0,
        "seed {seed}: the line carried something that is not a frame"
    );
    report.count("frames", decoded.frames);
    report.count("overrun bytes", stats.overrun_bytes);
    report.count("dropped frames", stats.dropped_frames);
    report.count("sent bytes", stats.sent_bytes);
    report
}

/// A random valid frame.
fn random_frame(rng: &mut SplitMix) -> Frame {
    let len = rng.below(9) as usize;
    let data: Vec<u8> = (0..len).map(|_| rng.next_u64() as u8).collect();
    Frame::new(rng.below(128) as u8, rng.below(128) as u8, &data).expect("a valid frame")
}

/// The feedback decoder: chunked and byte-by-byte decoding agree; every byte is a
/// frame's, dropped or pending; at most one frame is pending; after any garbage a
/// valid frame is decoded intact.
pub fn decoder(seed: u64, bytes: usize) -> Report {
    let mut noise = LineNoise::new(seed);
    let mut chunked = FrameDecoder::new();
    let mut bytewise = FrameDecoder::new();
    let mut report = Report::default();
    let mut chunk = Vec::new();
    let mut frames = Vec::new();
    let mut delivered: u64 = 0;
    while (report.bytes as usize) < bytes {
        chunk.clear();
        match noise.rng().below(4) {
            0 => noise.chunk(&mut chunk),
            1 => {
                // Valid frames with damage here and there.
                for _ in 0..noise.rng().below(40) {
                    random_frame(noise.rng()).encode_into(&mut chunk);
                    if noise.rng().below(6) == 0 && !chunk.is_empty() {
                        let at = noise.rng().below(chunk.len() as u64) as usize;
                        chunk[at] ^= 1 << noise.rng().below(8);
                    }
                }
            }
            _ => {
                let len = noise.rng().below(64) as usize;
                chunk.extend((0..len).map(|_| noise.rng().next_u64() as u8));
            }
        }
        // After any garbage, a valid frame is decoded intact.
        let probe = random_frame(noise.rng());
        let probe_at = chunk.len();
        probe.encode_into(&mut chunk);
        frames.clear();
        let mut rest = &chunk[..];
        while !rest.is_empty() {
            let cut = 1 + noise.rng().below(rest.len() as u64) as usize;
            let (piece, after) = rest.split_at(cut);
            frames.extend(chunked.push(piece));
            rest = after;
        }
        let by_byte: Vec<Frame> = chunk
            .iter()
            .filter_map(|&byte| bytewise.push_byte(byte))
            .collect();
        assert_eq!(frames, by_byte, "seed {seed}: chunking changed the frames");
        assert_eq!(chunked.stats(), bytewise.stats());
        assert_eq!(
            frames.last(),
            Some(&probe),
            "seed {seed}, byte {}: no resync after {probe_at} bytes",
            report.bytes
        );
        assert_eq!(chunked.pending(), 0);
        report.bytes += chunk.len() as u64;
        delivered += frames.iter().map(|f| f.encoded_len() as u64).sum::<u64>();
        let stats = chunked.stats();
        assert_eq!(
            delivered + stats.dropped_bytes,
            report.bytes,
            "seed {seed}: a byte is unaccounted for"
        );
        report.count("probes", 1);
    }
    let stats = chunked.stats();
    report.count("frames", stats.frames);
    report.count("stray bytes", stats.stray_bytes);
    report.count("truncated", stats.truncated_frames);
    report.count("overlong", stats.overlong_frames);
    report.count("malformed", stats.malformed_frames);
    report
}

/// Fragments of console text beyond the line noise: comments, line breaks, braces,
/// full-width and other non-ASCII characters.
const CONSOLE_EXTRAS: &[&str] = &[
    "# a comment; with ; inside\n",
    "\n",
    "#",
    "{",
    "}",
    "；",
    "ＱＰ",
    "é",
    "\u{0}",
    "qp [ 3 ] : -9000 ;",
    "*20;",
    "MP[1]=12;",
    "SN[3]=1234;",
    "QPx0A0B;",
    "QPx;",
    "x0",
];

/// The console parser: any text is parsed or refused with a line and column inside
/// it; what it accepts encodes in the standard form and reads back the same.
pub fn console(seed: u64, bytes: usize) -> Report {
    let mut noise = LineNoise::new(seed);
    let mut report = Report::default();
    let mut raw = Vec::new();
    while (report.bytes as usize) < bytes {
        raw.clear();
        let valid = noise.rng().below(2) == 0;
        let target = match noise.rng().below(16) {
            0 => 64 * 1024,
            _ if valid => noise.rng().below(512) as usize,
            _ => noise.rng().below(2048) as usize,
        };
        while raw.len() < target {
            match noise.rng().below(if valid { 256 } else { 3 }) {
                0 => {
                    let extra =
                        CONSOLE_EXTRAS[noise.rng().below(CONSOLE_EXTRAS.len() as u64) as usize];
                    raw.extend_from_slice(extra.as_bytes());
                }
                1 => noise.chunk(&mut raw),
                _ if valid => valid_instruction(noise.rng(), &mut raw),
                _ => noise.chunk(&mut raw),
            }
        }
        if noise.rng().below(3) == 0 {
            // Mostly valid text, so that parsing gets far.
            raw.retain(|&b| b.is_ascii_graphic() || b == b' ' || b == b'\n');
        }
        let text = String::from_utf8_lossy(&raw);
        report.bytes += text.len() as u64;
        match parse_script(&text) {
            Ok(instructions) => {
                let semicolons = text.matches(';').count() + text.matches('；').count();
                assert!(instructions.len() <= semicolons, "seed {seed}");
                for instruction in &instructions {
                    round_trip(seed, instruction);
                }
                report.count("scripts accepted", 1);
                report.count("instructions", instructions.len() as u64);
            }
            Err(error) => {
                let lines = text.split('\n').count() as u32;
                assert!(
                    (1..=lines).contains(&error.line) && error.column >= 1,
                    "seed {seed}: {error:?} outside the text"
                );
                let line = text.split('\n').nth(error.line as usize - 1).unwrap_or("");
                assert!(
                    error.column as usize <= line.chars().count() + 1,
                    "seed {seed}: column {} of a line of {} characters",
                    error.column,
                    line.chars().count()
                );
                assert!(!error.to_string().is_empty());
                report.count("scripts refused", 1);
            }
        }
    }
    report
}

/// Appends a well-formed instruction (its operand sometimes out of range) with some
/// spacing, case and comments around it.
fn valid_instruction(rng: &mut SplitMix, out: &mut Vec<u8>) {
    const FORMS: &[&str] = &[
        "*{s};",
        "QP[{i}]={n};",
        "QV[{i}]={n};",
        "QT[{i}]={t};",
        "qp [ {i} ] : {n} ;",
        "MO=1;",
        "MO=0;",
        "MO;",
        "SN;",
        "SN[{s}]={u};",
        "PA={n};",
        "SP={t};",
        "SD={u};",
        "BG;",
        "BG={u};",
        "PV={i};",
        "PV;",
        "MP[{p}]={i};",
        "MP[{p}];",
        "IE[{i}]=1;",
        "QP[{i}];",
        "ZZ;",
        "XYx0A0B;",
    ];
    let form = FORMS[rng.below(FORMS.len() as u64) as usize];
    let mut text = String::new();
    let mut rest = form;
    while let Some(open) = rest.find('{') {
        text.push_str(&rest[..open]);
        let kind = &rest[open + 1..open + 2];
        let value = match kind {
            // Now and then beyond the field's range.
            _ if rng.below(50) == 0 => (rng.next_u64() >> rng.below(64)).to_string(),
            "s" => rng.below(128).to_string(),
            "i" => rng.below(256).to_string(),
            "p" => rng.below(8).to_string(),
            "t" => (1 + rng.below(1000)).to_string(),
            "u" => (rng.next_u64() >> 33).to_string(),
            _ => ((rng.next_u64() as i64) >> (33 + rng.below(31))).to_string(),
        };
        text.push_str(&value);
        rest = &rest[open + 3..];
    }
    text.push_str(rest);
    out.extend_from_slice(text.as_bytes());
    match rng.below(8) {
        0 => out.push(b'\n'),
        1 => out.extend_from_slice(b"  # note\n"),
        _ => {}
    }
}

fn round_trip(seed: u64, instruction: &Instruction) {
    let encoded = instruction
        .encode(Form::Standard)
        .unwrap_or_else(|err| panic!("seed {seed}: {instruction:?} does not encode: {err}"));
    let text = std::str::from_utf8(encoded.as_bytes()).expect("encoded text is ASCII");
    assert_eq!(
        parse_script(text).as_deref(),
        Ok(std::slice::from_ref(instruction)),
        "seed {seed}: {text}"
    );
}

/// A random valid MBOX datagram of any kind.
fn random_datagram(rng: &mut SplitMix) -> Datagram {
    let route = Route {
        receiver: BoxAddress(rng.next_u64() as u16),
        replier: BoxAddress(rng.next_u64() as u16),
    };
    let kind = rng.below(4);
    if kind == 0 {
        let axes = AxisCount::ALL[rng.below(3) as usize];
        let pulses: Vec<i32> = (0..axes.count()).map(|_| rng.next_u64() as i32).collect();
        return Datagram::Motion(MotionFrame {
            mode: [TimeMode::Absolute, TimeMode::Relative][rng.below(2) as usize],
            route,
            sequence: rng.next_u64() as u32,
            // Now and then 0, the box's default.
            time_code: TimeCode::from_ms((rng.next_u64() >> rng.below(64)) as u32),
            positions_pulses: AxisPositions::from_slice(&pulses).expect("3, 6 or 10 axes"),
            digital: DigitalOutputs::from_bits(rng.next_u64() as u16),
            analog: [rng.next_u64() as u16, rng.next_u64() as u16],
        });
    }
    let start = rng.next_u64() as u16;
    let count = 1 + rng.below(40.min(0x1_0000 - u64::from(start)));
    let values = (0..count).map(|_| rng.next_u64() as u16).collect();
    let block = RegisterBlock::new(start, values).expect("a valid block");
    let read_bank = [ReadBank::Dn, ReadBank::Fn][rng.below(2) as usize];
    match kind {
        1 => Datagram::Read(RegisterRead {
            bank: read_bank,
            route,
            range: RegisterRange::new(start, count as usize).expect("a valid range"),
        }),
        2 => Datagram::ReadReply(RegisterReply {
            bank: read_bank,
            route,
            block,
        }),
        _ => Datagram::Write(RegisterWrite {
            bank: [WriteBank::FnVolatile, WriteBank::FnSaved, WriteBank::Cx][rng.below(3) as usize],
            route,
            block,
        }),
    }
}

/// Damages a datagram 1–4 times: a bit flipped, a byte replaced (often in the header),
/// the end cut off, or bytes added.
fn mutate(rng: &mut SplitMix, wire: &mut Vec<u8>) {
    for _ in 0..1 + rng.below(4) {
        match rng.below(5) {
            0 if !wire.is_empty() => {
                let at = rng.below(wire.len() as u64) as usize;
                wire[at] ^= 1 << rng.below(8);
            }
            1 if !wire.is_empty() => {
                let at = rng.below(wire.len().min(16) as u64) as usize;
                wire[at] = rng.next_u64() as u8;
            }
            2 => wire.truncate(rng.below(wire.len() as u64 + 1) as usize),
            3 => wire.extend((0..1 + rng.below(8)).map(|_| rng.next_u64() as u8)),
            _ => {}
        }
    }
}

/// The MBOX datagram decoder on single datagrams: random bytes, random bytes behind a
/// valid start, and valid datagrams damaged ([`mutate`]). It never panics, every
/// refusal has a message, whatever it accepts encodes back to the same bytes, and an
/// undamaged datagram decodes to itself.
pub fn mbox(seed: u64, bytes: usize) -> Report {
    let mut noise = LineNoise::new(seed);
    let mut report = Report::default();
    let mut wire = Vec::new();
    while (report.bytes as usize) < bytes {
        let rng = noise.rng();
        wire.clear();
        let original = match rng.below(8) {
            0 => {
                let len = rng.below(80) as usize;
                wire.extend((0..len).map(|_| rng.next_u64() as u8));
                None
            }
            1 => {
                let function = [0x1301_u16, 0x1401, 0x1101, 0x1102, 0x1201][rng.below(5) as usize];
                wire.extend([0x55, 0xAA, 0, 0]);
                wire.extend(function.to_be_bytes());
                wire.extend([0, rng.below(4) as u8]);
                let len = rng.below(80) as usize;
                wire.extend((0..len).map(|_| rng.next_u64() as u8));
                None
            }
            2 => {
                let datagram = random_datagram(rng);
                datagram.encode_into(&mut wire);
                Some(datagram)
            }
            _ => {
                random_datagram(rng).encode_into(&mut wire);
                mutate(rng, &mut wire);
                None
            }
        };
        report.bytes += wire.len() as u64;
        match (Datagram::decode(&wire), original) {
            (Ok(decoded), original) => {
                assert_eq!(decoded.encode(), wire, "seed {seed}: {decoded:?}");
                if let Some(original) = original {
                    assert_eq!(decoded, original, "seed {seed}");
                }
                report.count("accepted", 1);
            }
            (Err(error), None) => {
                assert!(!error.to_string().is_empty());
                report.count(refusal(&error), 1);
            }
            (Err(error), Some(original)) => {
                panic!("seed {seed}: {original:?} refused: {error}")
            }
        }
    }
    report
}

/// The kind of a refusal, for the report.
fn refusal(error: &DecodeError) -> &'static str {
    match error {
        DecodeError::Truncated { .. } => "truncated",
        DecodeError::BadMagic { .. } => "bad magic",
        DecodeError::BadPassCode { .. } => "bad pass code",
        DecodeError::UnknownFunction { .. } => "unknown function",
        DecodeError::UnknownChannel { .. } => "unknown channel",
        DecodeError::MotionLength { .. } => "motion length",
        DecodeError::RegisterLength { .. } => "register length",
        DecodeError::Registers { .. } => "register range",
    }
}

/// SCL command forms: `{i}` a signed integer, `{u}` an unsigned one, `{d}` a decimal,
/// `{p}` an I/O digit, `{c}` an input condition, `{l}` a level, `{q}` a Q line, `{s}` a
/// segment, `{r}` a register, `{j}` a jump condition, `{a}` an address or nothing.
const SCL_FORMS: &[&str] = &[
    "{a}FL",
    "{a}FP",
    "{a}FS{p}{c}",
    "{a}WI{p}{c}",
    "{a}DI{i}",
    "{a}DI",
    "{a}VE{d}",
    "{a}VE",
    "{a}AC{d}",
    "{a}DE{d}",
    "{a}EG{u}",
    "{a}SP{i}",
    "{a}EP{i}",
    "{a}IP",
    "{a}WT{d}",
    "{a}QG{q}",
    "{a}QW{s}",
    "{a}QU{s}",
    "{a}QU0",
    "{a}QR{r}{q}",
    "{a}QJ{j}{q}",
    "{a}QC{s}",
    "{a}QC",
    "{a}QL{s}",
    "{a}QS{s}",
    "{a}QX{s}",
    "{a}QE",
    "{a}TI{p}{l}",
    "{a}TR{r}{i}",
    "{a}CR{r}{r}",
    "{a}MT1",
    "{a}MT0",
    "{a}SO{p}{l}",
    "{a}R+{r}{r}",
    "{a}R-{r}{r}",
    "{a}R*{r}{r}",
    "{a}R/{r}{r}",
    "{a}R|{r}{r}",
    "{a}R&{r}{r}",
    "{a}RX{r}{i}",
    "{a}RM{r}{r}",
    "{a}SK",
    "{a}ST",
    "{a}ME",
    "{a}MD",
    "{a}SC",
    "{a}AL",
    "{a}AR",
];

/// Answer forms, with the same placeholders.
const SCL_ANSWERS: &[&str] = &[
    "{a}%",
    "{a}*",
    "{a}?",
    "{a}?{u}",
    "{a}IP={i}",
    "{a}SC={u}",
    "{a}VE={d}",
    "{a}RLh={i}",
];

/// Fills an SCL form's placeholders, now and then with something out of range.
fn scl_form(rng: &mut SplitMix, form: &str) -> String {
    let mut text = String::new();
    let mut rest = form;
    while let Some(open) = rest.find('{') {
        text.push_str(&rest[..open]);
        let pick = |rng: &mut SplitMix, set: &str| {
            let bytes = set.as_bytes();
            char::from(bytes[rng.below(bytes.len() as u64) as usize]).to_string()
        };
        let value = match &rest[open + 1..open + 2] {
            _ if rng.below(60) == 0 => (rng.next_u64() >> rng.below(64)).to_string(),
            "i" => ((rng.next_u64() as i64) >> (32 + rng.below(32))).to_string(),
            "u" => (rng.next_u64() >> (32 + rng.below(32))).to_string(),
            "d" => {
                let whole = rng.next_u64() >> (40 + rng.below(24));
                match rng.below(3) {
                    0 => whole.to_string(),
                    _ => format!("{whole}.{}", rng.below(1000) + 1),
                }
            }
            "p" => rng.below(10).to_string(),
            "c" => pick(rng, "HLRF"),
            "l" => pick(rng, "HL"),
            "q" => (1 + rng.below(62)).to_string(),
            "s" => (1 + rng.below(12)).to_string(),
            "r" => pick(rng, "0123456789:;<=>?@ABCDXYZ[]^_`aehz"),
            "j" => pick(rng, "TFPGLEUZ"),
            _ if rng.below(2) == 0 => String::new(),
            _ => pick(rng, "0123456789\"#$&'()+,-./:;<=>"),
        };
        text.push_str(&value);
        rest = &rest[open + 3..];
    }
    text.push_str(rest);
    text
}

/// The lines of `text` as the SCL script parser cuts them: CR LF, CR or LF end a line;
/// spaces and tabs around a command do not count; blank lines are skipped.
fn scl_lines(text: &str) -> Vec<&str> {
    text.split('\n')
        .flat_map(|line| line.split('\r'))
        .map(|line| line.trim_matches([' ', '\t']))
        .filter(|line| !line.is_empty())
        .collect()
}

/// Runs `check` on texts made by `text` from the seed's noise, until `bytes` bytes of
/// text have been checked; `check` may draw more from the noise.
fn on_texts(
    seed: u64,
    bytes: usize,
    text: fn(&mut LineNoise) -> String,
    mut check: impl FnMut(&mut LineNoise, &str, &mut Report),
) -> Report {
    let mut noise = LineNoise::new(seed);
    let mut report = Report::default();
    while (report.bytes as usize) < bytes {
        let text = text(&mut noise);
        report.bytes += text.len() as u64;
        check(&mut noise, &text, &mut report);
    }
    report
}

/// The SCL parsers: scripts of command lines (valid forms, out-of-range values, noise,
/// damaged bytes), single answers and eSCL datagrams. Nothing panics; a refusal points
/// inside the text; whatever is accepted prints back exactly as it was written (a
/// script line by line, an answer and a datagram byte for byte).
pub fn scl(seed: u64, bytes: usize) -> Report {
    on_texts(seed, bytes, scl_script, |noise, text, report| {
        match scl::parse_script(text) {
            Ok(requests) => {
                let lines = scl_lines(text);
                let printed: Vec<String> = requests.iter().map(ToString::to_string).collect();
                assert_eq!(printed, lines, "seed {seed}: {text:?}");
                report.count("scripts accepted", 1);
                report.count("commands", requests.len() as u64);
            }
            Err(error) => {
                let line_count = text.split('\n').flat_map(|l| l.split('\r')).count();
                assert!(
                    (1..=line_count as u32).contains(&error.line) && error.column >= 1,
                    "seed {seed}: {error:?} outside the text"
                );
                assert!(!error.to_string().is_empty());
                report.count("scripts refused", 1);
            }
        }
        // One answer: a valid form, sometimes damaged.
        let rng = noise.rng();
        let form = SCL_ANSWERS[rng.below(SCL_ANSWERS.len() as u64) as usize];
        let mut answer = scl_form(rng, form);
        if rng.below(3) == 0 && !answer.is_empty() {
            let at = rng.below(answer.len() as u64) as usize;
            let mut bytes = answer.into_bytes();
            bytes[at] = rng.next_u64() as u8 & 0x7F;
            answer = String::from_utf8_lossy(&bytes).into_owned();
        }
        report.bytes += answer.len() as u64;
        match Reply::parse(&answer) {
            Ok(reply) => {
                assert_eq!(
                    reply.to_string(),
                    answer.strip_suffix('\r').unwrap_or(&answer)
                );
                report.count("answers accepted", 1);
            }
            Err(error) => {
                assert!(!error.to_string().is_empty());
                report.count("answers refused", 1);
            }
        }
        // One eSCL datagram: a command's, sometimes damaged, or noise behind the header.
        let rng = noise.rng();
        let form = SCL_FORMS[rng.below(SCL_FORMS.len() as u64) as usize];
        let line = scl_form(rng, form);
        let mut datagram = vec![0x00, 0x07];
        datagram.extend_from_slice(line.as_bytes());
        datagram.push(b'\r');
        match rng.below(4) {
            0 => {
                let at = rng.below(datagram.len() as u64) as usize;
                datagram[at] = rng.next_u64() as u8;
            }
            1 => datagram.truncate(rng.below(datagram.len() as u64) as usize),
            _ => {}
        }
        report.bytes += datagram.len() as u64;
        match Request::from_escl(&datagram) {
            Ok(request) => {
                assert_eq!(request.to_escl(), datagram, "seed {seed}");
                report.count("datagrams accepted", 1);
            }
            Err(error) => {
                assert!(!error.to_string().is_empty());
                report.count("datagrams refused", 1);
            }
        }
    })
}

/// The SCL drive twin: a bus of three addressed drives (and the start wire) fed the
/// SCL target's scripts — valid lines, values out of range, noise — in chunks at
/// advancing times. Nothing panics, every answer line starts with an address of the
/// bus, positions stay finite; after any noise, a roll call (a CR, then `SK`, `AR` and
/// `IP` to each drive) is answered by every drive.
pub fn scl_twin(seed: u64, bytes: usize) -> Report {
    let drives = "012"
        .chars()
        .map(|c| {
            Drive::new(DriveConfig {
                address: Address::new(c),
                ..DriveConfig::default()
            })
        })
        .collect();
    let mut bus = Bus::new(drives);
    bus.wire(StartWire {
        from: Address::new('0').unwrap(),
        output: IoPoint::new(2).unwrap(),
        input: IoPoint::new(3).unwrap(),
    });
    let mut now_us = 0_u64;
    on_texts(seed, bytes, scl_script, |noise, text, report| {
        let mut rest = text.as_bytes();
        while !rest.is_empty() {
            let take = (1 + noise.rng().below(32) as usize).min(rest.len());
            let (chunk, after) = rest.split_at(take);
            rest = after;
            now_us += noise.rng().below(50_000);
            let answers = bus.receive(chunk, now_us);
            for line in String::from_utf8_lossy(&answers).split_terminator('\r') {
                assert!(line.starts_with(['0', '1', '2']), "seed {seed}: {line:?}");
                report.count("answer lines", 1);
            }
        }
        now_us += 1;
        let answers = bus.receive(b"\r0SK\r1SK\r2SK\r0AR\r1AR\r2AR\r0IP\r1IP\r2IP\r", now_us);
        let answers = String::from_utf8_lossy(&answers).into_owned();
        let lines: Vec<&str> = answers.split_terminator('\r').collect();
        assert!(lines.len() >= 9, "seed {seed}: {answers:?}");
        let roll_call = &lines[lines.len() - 9..];
        assert_eq!(
            roll_call[..6],
            ["0%", "1%", "2%", "0%", "1%", "2%"],
            "seed {seed}"
        );
        for (line, c) in roll_call[6..].iter().zip(['0', '1', '2']) {
            assert!(
                line.starts_with(&format!("{c}IP=")),
                "seed {seed}: {line:?}"
            );
        }
        for drive in bus.drives() {
            assert!(drive.position_counts().is_finite(), "seed {seed}");
            assert!(!drive.is_executing(), "seed {seed}: SK ends programs");
        }
        report.count("roll calls", 1);
    })
}

/// A script for the SCL target: valid command lines (now and then with spaces, values
/// out of range, blank lines), or mostly noise with a few bytes damaged.
fn scl_script(noise: &mut LineNoise) -> String {
    let valid = noise.rng().below(2) == 0;
    let length = noise.rng().below(if valid { 400 } else { 1200 }) as usize;
    let mut raw = Vec::with_capacity(length);
    while raw.len() < length {
        let rng = noise.rng();
        if rng.below(if valid { 64 } else { 3 }) == 0 {
            noise.chunk(&mut raw);
            continue;
        }
        let form = SCL_FORMS[rng.below(SCL_FORMS.len() as u64) as usize];
        let line = scl_form(rng, form);
        let spaces = if rng.below(8) == 0 { " \t" } else { "" };
        let end = ["\n", "\r", "\r\n", "\n\n"][rng.below(4) as usize];
        raw.extend_from_slice(format!("{spaces}{line}{spaces}{end}").as_bytes());
    }
    if !valid && !raw.is_empty() {
        for _ in 0..1 + noise.rng().below(3) {
            let at = noise.rng().below(raw.len() as u64) as usize;
            raw[at] ^= 1 << noise.rng().below(7);
        }
    }
    String::from_utf8_lossy(&raw).into_owned()
}

/// A number for the MBOX console: decimal or hex, mostly small or 16-bit, now and then
/// far beyond any field.
fn console_number(rng: &mut SplitMix) -> String {
    let value = match rng.below(16) {
        0 => rng.next_u64() >> rng.below(64),
        1..=5 => rng.below(0x1_0000),
        6..=8 => rng.below(5),
        _ => rng.below(256),
    };
    match rng.below(3) {
        0 => format!("0x{value:X}"),
        1 => format!("0X{value:04x}"),
        _ => value.to_string(),
    }
}

/// One of the first `common` words seven times in eight, else any of `words`.
fn mostly<'w>(rng: &mut SplitMix, common: usize, words: &[&'w str]) -> &'w str {
    let from = if rng.below(8) == 0 {
        words.len()
    } else {
        common
    };
    words[rng.below(from as u64) as usize]
}

/// One MBOX console command: every command, bank and target form, in any case, mostly
/// valid, now and then with a part missing, one too many, or a word that is wrong.
fn console_command(rng: &mut SplitMix) -> String {
    let mut words: Vec<String> = Vec::new();
    match rng.below(8) {
        0 => words.push(format!("@{}", rng.below(260))),
        1 => words.push(format!("@{}.{}", rng.below(260), rng.below(256))),
        2 => {
            let targets = [
                "@all",
                "@ALL/none",
                "@15.201/15.202",
                "@192.168.15.7",
                "@",
                "@x/",
            ];
            words.push(mostly(rng, 4, &targets).to_owned());
        }
        _ => {}
    }
    if !words.is_empty() && rng.below(32) == 0 {
        return words.join(" ");
    }
    let commands = [
        "read", "write", "save", "estop", "release", "reset", "effects", "ip", "Read", "SAVE",
        "stop",
    ];
    let command = mostly(rng, 10, &commands);
    words.push(command.to_owned());
    let operands = match command.to_ascii_lowercase().as_str() {
        "read" => 3,
        "write" | "save" => 3 + rng.below(5) as usize,
        "effects" | "ip" => 1,
        _ => 0,
    };
    let operands = match rng.below(32) {
        0 => operands.saturating_sub(1),
        1 => operands + 1,
        _ => operands,
    };
    for index in 0..operands {
        let word = match (index, command) {
            (_, "ip") if rng.below(8) != 0 => {
                let octets: Vec<String> = (0..4).map(|_| rng.below(257).to_string()).collect();
                octets.join(".")
            }
            (0, "read" | "write" | "save" | "Read" | "SAVE") if rng.below(32) != 0 => {
                // The banks the command takes first, then the others.
                let banks = match command {
                    "read" | "Read" => ["FN", "dn", "CX", "FX"],
                    "write" => ["fn", "CX", "DN", "FX"],
                    _ => ["FN", "Fn", "DN", "cx"],
                };
                mostly(rng, 2, &banks).to_owned()
            }
            _ => console_number(rng),
        };
        words.push(word);
    }
    let space = [" ", "  ", "\t", " \r"][rng.below(4) as usize];
    words.join(space)
}

/// A text for the MBOX console target: up to a dozen commands ended by new lines,
/// `;` or comments; in half of the texts, noise between them and one byte damaged.
fn console_text(noise: &mut LineNoise) -> String {
    let damaged = noise.rng().below(2) == 0;
    let mut raw = Vec::new();
    for _ in 0..noise.rng().below(12) {
        if noise.rng().below(if damaged { 4 } else { 64 }) == 0 {
            noise.chunk(&mut raw);
        }
        let rng = noise.rng();
        raw.extend_from_slice(console_command(rng).as_bytes());
        let end = ["\n", ";", " ; ", "\r\n", " # note; estop\n", "#"][rng.below(6) as usize];
        raw.extend_from_slice(end.as_bytes());
    }
    if damaged && !raw.is_empty() {
        let at = noise.rng().below(raw.len() as u64) as usize;
        raw[at] = noise.rng().next_u64() as u8;
    }
    String::from_utf8_lossy(&raw).into_owned()
}

/// The MBOX console's parser on texts of commands (valid, slightly wrong, and noise or
/// damaged bytes between them), with a random selected box. It never panics; a refusal
/// points inside the text (a line that exists, a column at most one past its end) and
/// says something; whatever it accepts prints to canonical texts that parse back to the
/// same operations, with any selected box.
pub fn mbox_console(seed: u64, bytes: usize) -> Report {
    on_texts(seed, bytes, console_text, |noise, text, report| {
        let rng = noise.rng();
        let selected = Route {
            receiver: BoxAddress([0xFFFF, 0x0FC9, rng.next_u64() as u16][rng.below(3) as usize]),
            replier: BoxAddress(rng.next_u64() as u16),
        };
        match mbox_console::parse(text, selected) {
            Ok(operations) => {
                let canonical: Vec<String> = operations.iter().map(ToString::to_string).collect();
                let again = mbox_console::parse(&canonical.join("\n"), Route::BROADCAST);
                assert_eq!(again.as_ref(), Ok(&operations), "seed {seed}: {text:?}");
                report.count("texts accepted", 1);
                report.count("operations", operations.len() as u64);
            }
            Err(error) => {
                let line = text.split('\n').nth((error.line as usize).wrapping_sub(1));
                let Some(line) = line else {
                    panic!("seed {seed}: {error:?} outside {text:?}");
                };
                assert!(
                    error.column >= 1 && error.column as usize <= line.chars().count() + 1,
                    "seed {seed}: {error:?} outside the line {line:?}"
                );
                assert!(!error.to_string().is_empty());
                report.count("texts refused", 1);
                report.count(console_refusal(&error.kind), 1);
            }
        }
    })
}

/// Every kind of MBOX console refusal, by its variant's name, for the report.
pub const CONSOLE_REFUSALS: [&str; 13] = [
    "UnknownCommand",
    "MissingCommand",
    "Missing",
    "NotABank",
    "WrongBank",
    "NotANumber",
    "OutOfRange",
    "ZeroCount",
    "Range",
    "Trailing",
    "NotAnIp",
    "BadTarget",
    "NoSubnet",
];

/// The kind of an MBOX console refusal: its variant's name.
fn console_refusal(kind: &ConsoleErrorKind) -> &'static str {
    let debug = format!("{kind:?}");
    let variant = debug.split([' ', '{', '(']).next().unwrap_or_default();
    CONSOLE_REFUSALS
        .into_iter()
        .find(|&name| name == variant)
        .unwrap_or_else(|| panic!("{variant} is not in CONSOLE_REFUSALS"))
}

/// A random valid `ArtDmx` or `ArtPoll`, and whether it is a poll.
fn random_artnet(rng: &mut SplitMix, wire: &mut Vec<u8>) -> bool {
    if rng.below(6) == 0 {
        wire.extend(artnet::encode_poll(artnet::ArtPoll {
            flags: rng.next_u64() as u8,
            diag_priority: rng.next_u64() as u8,
        }));
        return true;
    }
    let address = PortAddress::from_raw(rng.below(0x8000) as u16).expect("15 bits");
    let len = 2 * (1 + rng.below(256) as usize);
    let data: Vec<u8> = (0..len).map(|_| rng.next_u64() as u8).collect();
    wire.extend(artnet::encode_dmx(rng.next_u64() as u8, address, &data));
    false
}

/// The Art-Net decoder on single datagrams: random bytes, random bytes behind a valid
/// ID, valid packets and damaged ones ([`mutate`]). It never panics, every refusal has
/// a message, an accepted `ArtDmx` has an even 2–512 slots inside the datagram and a
/// 15-bit Port-Address, and an undamaged packet decodes to what was sent.
pub fn artnet(seed: u64, bytes: usize) -> Report {
    let mut noise = LineNoise::new(seed);
    let mut report = Report::default();
    let mut wire = Vec::new();
    while (report.bytes as usize) < bytes {
        let rng = noise.rng();
        wire.clear();
        let intact = match rng.below(8) {
            0 => {
                let len = rng.below(600) as usize;
                wire.extend((0..len).map(|_| rng.next_u64() as u8));
                false
            }
            1 => {
                wire.extend(artnet::ID);
                let op = [0x5000u16, 0x2000, 0x2100, 0x5200][rng.below(4) as usize];
                wire.extend(op.to_le_bytes());
                let len = rng.below(600) as usize;
                wire.extend((0..len).map(|_| rng.next_u64() as u8));
                false
            }
            2 => {
                random_artnet(rng, &mut wire);
                true
            }
            _ => {
                random_artnet(rng, &mut wire);
                mutate(rng, &mut wire);
                false
            }
        };
        report.bytes += wire.len() as u64;
        match artnet::decode(&wire) {
            Ok(artnet::Packet::Dmx(dmx)) => {
                assert!(dmx.data.len() >= 2 && dmx.data.len() <= 512 && dmx.data.len() % 2 == 0);
                assert!(dmx.port_address.raw() < 0x8000);
                assert!(wire.len() >= artnet::DMX_HEADER_LEN + dmx.data.len());
                if intact {
                    let again = artnet::encode_dmx(dmx.sequence, dmx.port_address, dmx.data);
                    assert_eq!(again, wire, "seed {seed}: {dmx:?}");
                }
                report.count("dmx", 1);
            }
            Ok(artnet::Packet::Poll(_)) => report.count("polls", 1),
            Ok(artnet::Packet::Other { .. }) => {
                assert!(
                    !intact,
                    "seed {seed}: a valid packet read as another OpCode"
                );
                report.count("other op codes", 1);
            }
            Err(error) => {
                assert!(!intact, "seed {seed}: refused {error}");
                assert!(!error.to_string().is_empty());
                report.count(
                    match error {
                        ArtNetError::Truncated { .. } => "truncated",
                        ArtNetError::BadId => "bad id",
                        ArtNetError::OldVersion { .. } => "old version",
                        ArtNetError::BadLength { .. } => "bad length",
                        ArtNetError::BadNet { .. } => "bad net",
                    },
                    1,
                );
            }
        }
    }
    report
}

/// A few CIDs, so that sources repeat.
fn random_cid(rng: &mut SplitMix) -> [u8; 16] {
    [rng.below(4) as u8 + 1; 16]
}

/// A random valid sACN data packet (universes 1–4 mostly) or discovery packet.
fn random_sacn(rng: &mut SplitMix, wire: &mut Vec<u8>, sequence: u8) {
    let cid = random_cid(rng);
    if rng.below(10) == 0 {
        let universes: Vec<u16> = (0..rng.below(600)).map(|u| u as u16 + 1).collect();
        wire.extend(sacn::encode_discovery(cid, &universes));
        return;
    }
    let len = rng.below(513) as usize;
    let data: Vec<u8> = (0..len).map(|_| rng.next_u64() as u8).collect();
    let options = rng.next_u64() as u8;
    let packet = sacn::DataPacket {
        cid,
        source_name: b"fuzz",
        priority: rng.below(201) as u8,
        sync_address: 0,
        sequence,
        options: sacn::Options {
            preview: options & 0x7 == 0,
            terminated: options & 0x38 == 0,
            force_sync: options & 0x40 == 0,
        },
        universe: if rng.below(8) == 0 {
            1 + rng.below(u64::from(sacn::MAX_UNIVERSE)) as u16
        } else {
            1 + rng.below(4) as u16
        },
        start_code: if rng.below(8) == 0 {
            rng.next_u64() as u8
        } else {
            0
        },
        data: &data,
    };
    wire.extend(sacn::encode_data(&packet));
}

/// The sACN decoder on single datagrams, as [`artnet`]: never a panic, refusals with
/// messages, an accepted data packet within E1.31's ranges that encodes and decodes
/// back to itself, an undamaged one decoded to exactly its bytes.
pub fn sacn(seed: u64, bytes: usize) -> Report {
    let mut noise = LineNoise::new(seed);
    let mut report = Report::default();
    let mut wire = Vec::new();
    let mut sequence = 0u8;
    while (report.bytes as usize) < bytes {
        let rng = noise.rng();
        wire.clear();
        sequence = sequence.wrapping_add(1);
        let intact = match rng.below(8) {
            0 => {
                let len = rng.below(700) as usize;
                wire.extend((0..len).map(|_| rng.next_u64() as u8));
                false
            }
            1 => {
                random_sacn(rng, &mut wire, sequence);
                let keep = rng.below(wire.len() as u64 + 1) as usize;
                for byte in &mut wire[keep..] {
                    *byte = rng.next_u64() as u8;
                }
                false
            }
            2 | 3 => {
                random_sacn(rng, &mut wire, sequence);
                true
            }
            4 | 5 => {
                // One field damaged, the lengths intact: vectors, DMP fields, count,
                // priority, universe.
                const FIELDS: [usize; 13] = [
                    21, 43, 108, 113, 114, 117, 118, 119, 120, 121, 122, 123, 124,
                ];
                random_sacn(rng, &mut wire, sequence);
                let at = FIELDS[rng.below(FIELDS.len() as u64) as usize];
                let value = rng.next_u64() as u8;
                if let Some(byte) = wire.get_mut(at) {
                    // A priority from 128 up: above 200 four times in nine.
                    *byte = if at == 108 { value | 0x80 } else { value };
                }
                false
            }
            _ => {
                random_sacn(rng, &mut wire, sequence);
                mutate(rng, &mut wire);
                false
            }
        };
        report.bytes += wire.len() as u64;
        match sacn::decode(&wire) {
            Ok(sacn::Packet::Data(packet)) => {
                assert!(packet.priority <= sacn::MAX_PRIORITY);
                assert!((1..=sacn::MAX_UNIVERSE).contains(&packet.universe));
                assert!(packet.data.len() <= 512);
                let again = sacn::encode_data(&packet);
                assert_eq!(sacn::decode(&again), Ok(sacn::Packet::Data(packet.clone())));
                if intact {
                    assert_eq!(again, wire, "seed {seed}");
                }
                report.count("data", 1);
            }
            Ok(sacn::Packet::Discovery { .. }) => report.count("discovery", 1),
            Ok(sacn::Packet::Sync { .. }) => report.count("sync", 1),
            Err(error) => {
                assert!(!intact, "seed {seed}: refused {error}");
                assert!(!error.to_string().is_empty());
                report.count(
                    match error {
                        SacnError::Truncated { .. } => "truncated",
                        SacnError::TooLong { .. } => "too long",
                        SacnError::BadPreamble { .. } => "bad preamble",
                        SacnError::BadIdentifier => "bad identifier",
                        SacnError::BadLength { .. } => "bad length",
                        SacnError::BadRootVector { .. } => "bad root vector",
                        SacnError::BadFramingVector { .. } => "bad framing vector",
                        SacnError::BadDmp => "bad dmp",
                        SacnError::BadCount { .. } => "bad count",
                        SacnError::BadPriority { .. } => "bad priority",
                        SacnError::BadUniverse { .. } => "bad universe",
                    },
                    1,
                );
            }
        }
    }
    report
}

/// The merge fed the packets the decoders accept (Art-Net and sACN, valid and
/// damaged, from a few senders, time advancing by random steps): it never panics,
/// keeps at most [`MAX_SOURCES`] sources per universe, an accepted packet's source
/// wins its universe at once unless a live source of higher priority holds it, a
/// terminated source never wins, and after the timeout nothing does.
pub fn live_merge(seed: u64, bytes: usize) -> Report {
    const TIMEOUT_MS: u64 = 2500;
    let mut noise = LineNoise::new(seed);
    let mut report = Report::default();
    let mut merge = Merge::new([1, 2, 3], TIMEOUT_MS);
    let mut wire = Vec::new();
    let mut now_ms = 0u64;
    let mut sequences = [0u8; 256];
    while (report.bytes as usize) < bytes {
        let rng = noise.rng();
        now_ms += match rng.below(100) {
            0 => 3000,
            1..=10 => rng.below(500),
            _ => rng.below(25),
        };
        wire.clear();
        let artnet_source = rng.below(2) == 0;
        if artnet_source {
            let address = PortAddress::from_raw(rng.below(4) as u16).expect("15 bits");
            let len = 2 * (1 + rng.below(256) as usize);
            let data: Vec<u8> = (0..len).map(|_| rng.next_u64() as u8).collect();
            wire.extend(artnet::encode_dmx(0, address, &data));
        } else {
            let cid = random_cid(rng);
            let sequence = &mut sequences[usize::from(cid[0])];
            // Mostly in order, now and then late or restarted.
            *sequence = match rng.below(10) {
                0 => sequence.wrapping_sub(rng.below(40) as u8),
                _ => sequence.wrapping_add(1),
            };
            let seq = *sequence;
            random_sacn(rng, &mut wire, seq);
            wire[22..38].copy_from_slice(&cid);
        }
        if rng.below(4) == 0 {
            mutate(rng, &mut wire);
        }
        report.bytes += wire.len() as u64;
        let sender = [10, 0, 0, rng.below(3) as u8];
        let (fed, universe, priority, source) = if artnet_source {
            match artnet::decode(&wire) {
                Ok(artnet::Packet::Dmx(dmx)) => (
                    merge.artnet(sender, &dmx, now_ms),
                    dmx.port_address.universe(),
                    sacn::DEFAULT_PRIORITY,
                    floatball_shared::live::merge::SourceId::ArtNet(sender),
                ),
                _ => {
                    report.count("refused", 1);
                    continue;
                }
            }
        } else {
            match sacn::decode(&wire) {
                Ok(sacn::Packet::Data(packet)) => (
                    merge.sacn(&packet, now_ms),
                    packet.universe,
                    packet.priority,
                    floatball_shared::live::merge::SourceId::Sacn(packet.cid),
                ),
                _ => {
                    report.count("refused", 1);
                    continue;
                }
            }
        };
        for universe in merge.universes().collect::<Vec<_>>() {
            assert!(merge.source_count(universe) <= MAX_SOURCES);
            if let Some(winner) = merge.winner(universe, now_ms) {
                assert!(winner.slots.len() <= 512);
            }
        }
        match fed {
            Fed::Accepted => {
                let winner = merge.winner(universe, now_ms).expect("a winner");
                assert!(winner.priority >= priority, "seed {seed}");
                if winner.priority == priority {
                    assert_eq!(winner.source, source, "seed {seed}: the latest wins");
                }
                report.count("accepted", 1);
            }
            Fed::Terminated => {
                if let Some(winner) = merge.winner(universe, now_ms) {
                    assert_ne!(winner.source, source, "seed {seed}: terminated yet winning");
                }
                report.count("terminated", 1);
            }
            Fed::NotPatched => report.count("not patched", 1),
            Fed::OutOfSequence => report.count("out of sequence", 1),
            Fed::Preview => report.count("preview", 1),
            Fed::StartCode => report.count("start code", 1),
            Fed::TooManySources => report.count("too many sources", 1),
        }
        if rng.below(50) == 0 {
            merge.expire(now_ms);
            let later = now_ms + TIMEOUT_MS + 1;
            for universe in [1, 2, 3] {
                assert!(merge.winner(universe, later).is_none());
            }
        }
    }
    report
}
