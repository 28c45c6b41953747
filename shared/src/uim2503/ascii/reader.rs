//! Bytes → instructions, the way a gateway reads its serial line.
//!
//! Bytes arrive in any chunking. Whitespace between instructions is skipped; everything
//! from the first other byte up to and including the next `;` is one instruction, held
//! in a buffer of [`MAX_LEN`] bytes. Longer text is an error once its `;` arrives (the
//! bytes in between are counted, not kept); any error ends at that `;` and reading goes
//! on with the next instruction. Without a `;` nothing is ever yielded, as on the real
//! gateway. `#` comments are a script feature and are not accepted here.
//!
//! ```
//! use floatball_shared::uim2503::ascii::{Instruction, InstructionReader, ParseErrorKind};
//!
//! let mut reader = InstructionReader::new();
//! assert_eq!(reader.push(b"*20;P").count(), 1);
//! assert_eq!(reader.pending(), 1);
//!
//! let read: Vec<_> = reader.push(b"V=3;QT[0]=0;BG;").collect();
//! assert_eq!(read[0], Ok(Instruction::PvtStart { row: Some(3) }));
//! assert!(matches!(read[1], Err(ref e) if matches!(e.kind, ParseErrorKind::OutOfRange(_))));
//! assert_eq!(read[2], Ok(Instruction::Begin { at_us: None }));
//! ```

use super::parse::parse_received;
use super::{Instruction, MAX_LEN, ParseError, ParseErrorKind};

/// Reads instructions from raw bytes with a fixed 20-byte buffer; see the
/// [module documentation](self).
#[derive(Debug, Clone)]
pub struct InstructionReader {
    buffer: [u8; MAX_LEN],
    /// Bytes of the current instruction so far, including any beyond the buffer.
    length: usize,
}

impl Default for InstructionReader {
    fn default() -> Self {
        Self::new()
    }
}

impl InstructionReader {
    /// A reader between instructions.
    pub fn new() -> Self {
        Self {
            buffer: [0; MAX_LEN],
            length: 0,
        }
    }

    /// Feeds one byte; yields the instruction it completes, if it is a `;`.
    ///
    /// Errors carry the line and column within the instruction (line 1, column 1 is its
    /// first byte). An instruction over 20 bytes is [`ParseErrorKind::TooLong`] at
    /// column 1.
    pub fn push_byte(&mut self, byte: u8) -> Option<Result<Instruction, ParseError>> {
        if self.length == 0 && byte.is_ascii_whitespace() {
            return None;
        }
        if let Some(slot) = self.buffer.get_mut(self.length) {
            *slot = byte;
        }
        self.length = self.length.saturating_add(1);
        if byte != b';' {
            return None;
        }
        let length = std::mem::take(&mut self.length);
        Some(match self.buffer.get(..length) {
            Some(text) => parse_received(text),
            None => Err(ParseError {
                line: 1,
                column: 1,
                kind: ParseErrorKind::TooLong { length },
            }),
        })
    }

    /// Feeds a chunk of bytes; the iterator yields one result per `;` in it. Bytes the
    /// iterator has not reached when it is dropped are not read.
    pub fn push<'r, 'b>(&'r mut self, bytes: &'b [u8]) -> ReadInstructions<'r, 'b> {
        ReadInstructions {
            reader: self,
            bytes,
        }
    }

    /// The number of bytes of an instruction still waiting for its `;`.
    pub fn pending(&self) -> usize {
        self.length
    }
}

/// The instructions completed by one chunk: see [`InstructionReader::push`].
#[derive(Debug)]
#[must_use = "bytes are read only as the iterator is advanced"]
pub struct ReadInstructions<'r, 'b> {
    reader: &'r mut InstructionReader,
    bytes: &'b [u8],
}

impl Iterator for ReadInstructions<'_, '_> {
    type Item = Result<Instruction, ParseError>;

    fn next(&mut self) -> Option<Self::Item> {
        while let Some((&byte, rest)) = self.bytes.split_first() {
            self.bytes = rest;
            if let Some(read) = self.reader.push_byte(byte) {
                return Some(read);
            }
        }
        None
    }
}
