//! Line noise for robustness tests: what a gateway's serial line sees when a cable is
//! loose, the baud rate is wrong or a host dies mid-instruction.
//!
//! [`LineNoise`] makes an endless, reproducible stream from a seed: random binary
//! chunks alternating with chunks built from instruction fragments (`*0;`, `QP[`,
//! `]=`, `SN[`, `MO=1;`, signed numbers, `99999999999`, ...), so that many fragments
//! join into instructions the units carry out — selections, PVT rows, moves,
//! renumbering — and many do not. The same seed always gives the same bytes (a small
//! built-in generator, no clock, no randomness from outside).
//!
//! ```
//! use floatball_shared::uim2503::sim::noise::LineNoise;
//!
//! let mut bytes = Vec::new();
//! LineNoise::new(7).fill(&mut bytes, 10_000);
//! assert_eq!(bytes.len(), 10_000);
//! let mut again = Vec::new();
//! LineNoise::new(7).fill(&mut again, 10_000);
//! assert_eq!(bytes, again);
//! ```

/// The fragments instruction-like chunks are made of.
const FRAGMENTS: &[&str] = &[
    "*0;",
    "*5;",
    "*1;",
    "QP[",
    "]=",
    "QV[3]=",
    "QT[",
    "MP[",
    "PV=",
    "BG;",
    "BG=",
    "SN;",
    "SN[",
    "MO=1;",
    "MO=0;",
    "PA=",
    "SP=",
    "SD=",
    "IE[",
    ";",
    "=",
    "x",
    "-",
    "]",
    "[",
    "99999999999",
    " ",
    "\r\n",
    "MO;",
    "PV;",
    "PA;",
];

/// A small, fast, seeded pseudo-random generator (SplitMix64).
#[derive(Debug, Clone)]
pub struct SplitMix(u64);

impl SplitMix {
    /// A generator from `seed`.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A number below `bound` (at least 1); the slight bias does not matter here.
    pub fn below(&mut self, bound: u64) -> u64 {
        self.next_u64() % bound.max(1)
    }
}

/// An endless stream of line noise; see the [module documentation](self).
#[derive(Debug, Clone)]
pub struct LineNoise {
    rng: SplitMix,
    /// The next chunk is binary.
    binary: bool,
}

impl LineNoise {
    /// The stream for `seed`.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self {
            rng: SplitMix::new(seed),
            binary: seed & 1 == 0,
        }
    }

    /// The generator behind the stream, for choices that go with it (chunk sizes,
    /// timing).
    pub fn rng(&mut self) -> &mut SplitMix {
        &mut self.rng
    }

    /// Appends the next chunk (1–512 bytes) to `out`.
    pub fn chunk(&mut self, out: &mut Vec<u8>) {
        let len = 1 + self.rng.below(512) as usize;
        let start = out.len();
        if self.binary {
            while out.len() - start < len {
                out.extend_from_slice(&self.rng.next_u64().to_le_bytes());
            }
            out.truncate(start + len);
        } else {
            while out.len() - start < len {
                self.fragment(out);
            }
        }
        self.binary = !self.binary;
    }

    /// Appends exactly `len` bytes of noise to `out`.
    pub fn fill(&mut self, out: &mut Vec<u8>, len: usize) {
        let end = out.len() + len;
        while out.len() < end {
            self.chunk(out);
        }
        out.truncate(end);
    }

    fn fragment(&mut self, out: &mut Vec<u8>) {
        let choice = self.rng.below(FRAGMENTS.len() as u64 + 6);
        match FRAGMENTS.get(choice as usize) {
            Some(fragment) => out.extend_from_slice(fragment.as_bytes()),
            None => {
                // A signed number of any size, small ones more often.
                let bits = self.rng.below(64);
                let number = (self.rng.next_u64() as i64) >> bits;
                out.extend_from_slice(number.to_string().as_bytes());
            }
        }
    }
}
