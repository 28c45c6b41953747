//! The gateway's own three-letter commands (`docs/uim2503.md` §2, `docs/protocol-notes.md` §3), which it acts on
//! itself instead of passing them to the units, and the greeting's answer.
//!
//! - `ABC;`, the greeting (hand-shake, presence check): the gateway answers with bytes
//!   that start [`GREETING_ANSWER`] (`AA AB AC`). Inert: it cannot move anything.
//! - `BDR=x;`, the line speed (x = 9600…115200 baud): the gateway stores it and uses it
//!   from its next restart (power cycle) on. Not inert: it changes the installation.
//!
//! They are [`Instruction::Gateway`](super::Instruction::Gateway), never unit
//! instructions: no `*N;` station applies to them. [`GreetingWatch`] finds the answer
//! in the bytes read from the gateway, in any chunking. The answer cannot be mistaken
//! for a feedback frame nor found inside one: a frame's data bytes never have bit 7
//! set, its header is `0xFy` and its tail `0xEy`.

/// The greeting's text.
pub const GREETING: &[u8] = b"ABC;";

/// The bytes the gateway's answer to the greeting starts with.
pub const GREETING_ANSWER: [u8; 3] = [0xAA, 0xAB, 0xAC];

/// The slowest line speed `BDR=x;` accepts, baud (also the factory speed).
pub const MIN_BAUD: u32 = 9600;

/// The fastest line speed `BDR=x;` accepts, baud.
pub const MAX_BAUD: u32 = 115_200;

/// A command for the gateway itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GatewayCommand {
    /// `ABC;`: the greeting; the gateway answers `AA AB AC`.
    Greet,
    /// `BDR=x;`: the line speed from the gateway's next restart on, [`MIN_BAUD`] to
    /// [`MAX_BAUD`].
    SetBaud {
        /// The new speed, baud.
        baud: u32,
    },
}

impl GatewayCommand {
    /// The three upper-case letters.
    pub fn letters(self) -> [u8; 3] {
        match self {
            Self::Greet => *b"ABC",
            Self::SetBaud { .. } => *b"BDR",
        }
    }

    /// Whether it is safe while the e-stop is latched: the greeting is, a speed change
    /// is not.
    pub fn is_inert(self) -> bool {
        matches!(self, Self::Greet)
    }
}

/// Finds [`GREETING_ANSWER`] in bytes read from the gateway, however they are
/// chunked. Other bytes are left to the feedback decoder (which skips the answer as
/// noise: none of its bytes is a frame header).
#[derive(Debug, Clone, Default)]
pub struct GreetingWatch {
    /// How many bytes of the answer the last bytes matched.
    matched: usize,
}

impl GreetingWatch {
    /// A watch that has seen nothing.
    pub fn new() -> Self {
        Self::default()
    }

    /// Reads `bytes`; returns how many complete answers end in them.
    pub fn push(&mut self, bytes: &[u8]) -> usize {
        let mut answers = 0;
        for &byte in bytes {
            if GREETING_ANSWER.get(self.matched) == Some(&byte) {
                self.matched += 1;
            } else {
                // `AA` is the only byte that can start an answer again.
                self.matched = usize::from(byte == GREETING_ANSWER[0]);
            }
            if self.matched == GREETING_ANSWER.len() {
                answers += 1;
                self.matched = 0;
            }
        }
        answers
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::{Form, Instruction, InstructionReader, ParseErrorKind, parse_script};
    use super::*;

    #[test]
    fn the_greeting_and_the_speed_change_parse_encode_and_read() {
        let parsed = parse_script("abc;  BDR=115200;\nbdr 9600 ;BDR:19200;").unwrap();
        assert_eq!(
            parsed,
            [
                Instruction::Gateway(GatewayCommand::Greet),
                Instruction::Gateway(GatewayCommand::SetBaud { baud: 115_200 }),
                Instruction::Gateway(GatewayCommand::SetBaud { baud: 9600 }),
                Instruction::Gateway(GatewayCommand::SetBaud { baud: 19_200 }),
            ]
        );
        let texts: Vec<String> = parsed.iter().map(ToString::to_string).collect();
        assert_eq!(texts, ["ABC;", "BDR=115200;", "BDR=9600;", "BDR=19200;"]);
        let set = Instruction::Gateway(GatewayCommand::SetBaud { baud: 57_600 });
        assert_eq!(set.encode(Form::Compact).unwrap().as_bytes(), b"BDR57600;");
        assert_eq!(set.encoded_len(Form::Compact), 9);
        assert_eq!(set.encoded_len(Form::Standard), 10);
        let greet = Instruction::Gateway(GatewayCommand::Greet);
        assert_eq!(greet.encode(Form::Compact).unwrap().as_bytes(), GREETING);
        assert_eq!(greet.mnemonic(), None);
        let read: Vec<_> = InstructionReader::new()
            .push(b"*5;ABC;BDR=38400;PV;")
            .collect();
        assert_eq!(
            read,
            [
                Ok(Instruction::Select { station: 5 }),
                Ok(greet),
                Ok(Instruction::Gateway(GatewayCommand::SetBaud {
                    baud: 38_400
                })),
                Ok(Instruction::PvtStart { row: None }),
            ]
        );
    }

    #[test]
    fn only_the_greeting_is_inert() {
        assert!(Instruction::Gateway(GatewayCommand::Greet).is_inert());
        assert!(!Instruction::Gateway(GatewayCommand::SetBaud { baud: 9600 }).is_inert());
    }

    #[test]
    fn a_speed_outside_the_range_or_missing_is_refused_with_its_place() {
        let error = parse_script("ABC;\nBDR=4800;").unwrap_err();
        assert_eq!((error.line, error.column), (2, 5));
        assert!(
            matches!(error.kind, ParseErrorKind::OutOfRange(_)),
            "{error}"
        );
        assert_eq!(
            error.to_string(),
            "line 2, column 5: the line speed of BDR (baud) must be 9600–115200, found 4800"
        );
        let error = parse_script("BDR;").unwrap_err();
        assert_eq!(
            error.to_string(),
            "line 1, column 4: expected the line speed after `BDR=` (9600–115200 baud), \
             found `;`"
        );
        assert!(parse_script("BDR=99999999999999999999999;").is_err());
        assert!(parse_script("ABC=1;").is_err());
        assert!(parse_script("AB C;").is_err());
        assert!(
            Instruction::Gateway(GatewayCommand::SetBaud { baud: 300 })
                .encode(Form::Standard)
                .is_err()
        );
        // Other three-letter words stay what they were: a mnemonic followed by junk.
        let error = parse_script("ABD;").unwrap_err();
        assert_eq!(error.column, 3, "{error}");
    }

    #[test]
    fn the_answer_is_found_in_any_chunking_among_frames() {
        let stream = [
            0x10, 0xAA, 0xAA, 0xAB, 0xAC, 0xF0, 0x05, 0x0D, 0xE0, 0xAA, 0xAB, 0xAC, 0xAA, 0xAC,
        ];
        for cut in 0..=stream.len() {
            let mut watch = GreetingWatch::new();
            let (head, tail) = stream.split_at(cut);
            assert_eq!(watch.push(head) + watch.push(tail), 2, "cut at {cut}");
        }
        let mut watch = GreetingWatch::new();
        assert_eq!(watch.push(&[0xAA, 0xAB]), 0);
        assert_eq!(watch.push(&[0x00, 0xAC]), 0);
    }
}
