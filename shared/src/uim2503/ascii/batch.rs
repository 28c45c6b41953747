//! [`Batch`]: encoded instructions on their way to a gateway.
//!
//! A batch can only be built by encoding typed [`Instruction`]s, so nothing reaches a
//! serial line that the codec has not validated (`docs/architecture.md` §5), and the link knows where
//! every instruction ends: it writes one instruction at a time so an e-stop never waits
//! behind more than one.

use super::{EncodeError, Form, Instruction};

/// Encoded, validated instructions, in order.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
#[must_use]
pub struct Batch {
    bytes: Vec<u8>,
    /// Length of each instruction in `bytes`, in order (each ≤ 20).
    lens: Vec<u8>,
}

impl Batch {
    /// An empty batch.
    pub fn new() -> Self {
        Self::default()
    }

    /// Encodes `instructions` in `form`.
    ///
    /// # Errors
    /// The first instruction the gateway would refuse (too long, out of range).
    pub fn encode(instructions: &[Instruction], form: Form) -> Result<Self, EncodeError> {
        let mut batch = Self::new();
        for instruction in instructions {
            batch.push(instruction, form)?;
        }
        Ok(batch)
    }

    /// Appends one instruction.
    ///
    /// # Errors
    /// The codec's refusal; the batch is unchanged.
    pub fn push(&mut self, instruction: &Instruction, form: Form) -> Result<(), EncodeError> {
        let len = instruction.encode_into(form, &mut self.bytes)?;
        // The codec refuses anything over 20 characters, so this always fits.
        self.lens.push(u8::try_from(len).unwrap_or(u8::MAX));
        Ok(())
    }

    /// Appends every instruction of `other`.
    pub fn extend(&mut self, other: &Batch) {
        self.bytes.extend_from_slice(&other.bytes);
        self.lens.extend_from_slice(&other.lens);
    }

    /// The bytes as they go on the wire.
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// Number of bytes.
    pub fn len(&self) -> usize {
        self.bytes.len()
    }

    /// Whether there is nothing to send.
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// Number of instructions.
    pub fn instruction_count(&self) -> usize {
        self.lens.len()
    }

    /// Each instruction's bytes, in order.
    pub fn instructions(&self) -> impl Iterator<Item = &[u8]> + '_ {
        let mut start = 0;
        self.lens.iter().map(move |&len| {
            let end = start + usize::from(len);
            let chunk = &self.bytes[start..end];
            start = end;
            chunk
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use crate::uim2503::ascii::parse_script;

    #[test]
    fn splits_at_instruction_boundaries() {
        let instructions = parse_script("*5; QP[3]=1000; QV[3]=0; QT[3]=100;").unwrap();
        let batch = Batch::encode(&instructions, Form::Standard).unwrap();
        let chunks: Vec<&[u8]> = batch.instructions().collect();
        assert_eq!(
            chunks,
            [&b"*5;"[..], b"QP[3]=1000;", b"QV[3]=0;", b"QT[3]=100;"]
        );
        assert_eq!(batch.as_bytes(), b"*5;QP[3]=1000;QV[3]=0;QT[3]=100;");
        assert_eq!(batch.instruction_count(), 4);
    }

    #[test]
    fn a_refused_instruction_leaves_the_batch_unchanged() {
        let mut batch = Batch::encode(&parse_script("MO=1;").unwrap(), Form::Compact).unwrap();
        let refused = Instruction::PvtTime {
            row: 3,
            duration_ms: Some(0),
        };
        assert!(batch.push(&refused, Form::Standard).is_err());
        assert_eq!(batch.as_bytes(), b"MO1;");
        assert_eq!(batch.instruction_count(), 1);
    }
}
