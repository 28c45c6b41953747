//! Patterns' parameters as data: what each is ([`ParamSpec`], [`ParamKind`]: key,
//! label, help, unit, range, default, step), the values a recipe gives ([`Value`],
//! [`Params`]) and the [`Reader`] a pattern's builder reads them with: a missing value
//! gives the default, a number out of range is clamped with a [`Note`], a value of the
//! wrong type or an unknown key is refused.
//!
//! Files (a picture) travel as base64 text in recipes ([`encode_base64`],
//! [`decode_base64`]).
//!
//! ```
//! use floatball_shared::create::params::{ParamKind, ParamSpec, Params, Reader, Value};
//!
//! const SPECS: &[ParamSpec] = &[ParamSpec {
//!     key: "speed_m_s",
//!     label: "Speed",
//!     help: "How fast the wave travels.",
//!     kind: ParamKind::Number { min: 0.0, max: 5.0, step: 0.1, default: 0.5, unit: "m/s" },
//! }];
//! let mut params = Params::new();
//! params.insert("speed_m_s".into(), Value::Number(6.0));
//! let mut reader = Reader::new("wave", SPECS, &params, 0).unwrap();
//! assert_eq!(reader.number("speed_m_s"), 5.0);
//! assert_eq!(
//!     reader.notes()[0].to_string(),
//!     "speed_m_s of wave 1 clamped from 6 to 5 m/s (the range is 0 to 5)"
//! );
//! ```

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::{Change, CreateError, Note, number};

/// What kind of value a parameter takes, its range and default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamKind {
    /// A number in [min, max]; the page shows a slider with `step`, the CLI a
    /// `--key <value>` flag.
    Number {
        /// Smallest value.
        min: f64,
        /// Largest value.
        max: f64,
        /// A slider's step.
        step: f64,
        /// The value when none is given.
        default: f64,
        /// The unit (`"mm"`, `"m/s"`, `"s"`, `"deg"`; empty for a plain number).
        unit: &'static str,
    },
    /// One of a few words (e.g. direction "left" | "right" | "up" | "down"; text
    /// "raised" | "lowered").
    Choice {
        /// The words allowed.
        options: &'static [&'static str],
        /// The word when none is given.
        default: &'static str,
    },
    /// Free text (the word to show; a CJK bitmap as lines of '#' and '.').
    Text {
        /// The text when none is given.
        default: &'static str,
        /// Most characters allowed.
        max_chars: usize,
    },
    /// A file's bytes (a PNG or JPEG picture), base64 in the recipe, a path on the CLI.
    Bytes {
        /// Largest file allowed, bytes.
        max_bytes: usize,
    },
}

impl ParamKind {
    /// A number from `min` to `max` in steps of `step`, `default` when none is given,
    /// in `unit` (the patterns' tables, one line each).
    #[must_use]
    pub const fn number(min: f64, max: f64, step: f64, default: f64, unit: &'static str) -> Self {
        Self::Number {
            min,
            max,
            step,
            default,
            unit,
        }
    }

    /// A height below the top, mm: anywhere in a UFQ750's travel (0–7500 mm, the
    /// installation's own travel limits it when rendered), in steps of 10 mm.
    #[must_use]
    pub const fn height_mm(default: f64) -> Self {
        Self::number(0.0, crate::show::DEFAULT_TRAVEL_MM, 10.0, default, "mm")
    }

    /// What a value must be, in words: "a number from 0 to 5 m/s", "one of: left,
    /// right", "text of at most 40 characters", "a file of at most 4194304 bytes".
    #[must_use]
    pub fn expected(&self) -> String {
        match *self {
            Self::Number { min, max, unit, .. } => {
                let unit = if unit.is_empty() {
                    String::new()
                } else {
                    format!(" {unit}")
                };
                format!("a number from {} to {}{unit}", number(min), number(max))
            }
            Self::Choice { options, .. } => format!("one of: {}", options.join(", ")),
            Self::Text { max_chars, .. } => format!("text of at most {max_chars} characters"),
            Self::Bytes { max_bytes } => {
                format!("a file (base64 in a recipe) of at most {max_bytes} bytes")
            }
        }
    }

    /// The default as a [`Value`]; `None` for bytes (no default file).
    #[must_use]
    pub fn default_value(&self) -> Option<Value> {
        match *self {
            Self::Number { default, .. } => Some(Value::Number(default)),
            Self::Choice { default, .. } => Some(Value::Text(default.to_owned())),
            Self::Text { default, .. } => Some(Value::Text(default.to_owned())),
            Self::Bytes { .. } => None,
        }
    }
}

/// One parameter of a pattern.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    /// Its key in recipes and its CLI flag (`--key`), with its unit (`speed_m_s`).
    pub key: &'static str,
    /// English label; the app translates by pattern name and key.
    pub label: &'static str,
    /// One sentence: what it does.
    pub help: &'static str,
    /// Its kind, range and default.
    pub kind: ParamKind,
}

/// A parameter's value in a recipe: a number, or text (a choice, free text, or a
/// file's bytes as base64).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
#[serde(untagged)]
pub enum Value {
    /// A number.
    Number(f64),
    /// Text; bytes are text holding base64.
    Text(String),
}

/// A segment's parameters by key, in key order (so a recipe's JSON is deterministic).
pub type Params = BTreeMap<String, Value>;

/// Reading a pattern's parameters: missing → default; out of range → clamped with a
/// [`Note`]; wrong type or unknown key → refused when the reader is made.
#[derive(Debug)]
pub struct Reader<'a> {
    pattern: &'static str,
    specs: &'static [ParamSpec],
    params: &'a Params,
    segment: usize,
    notes: Vec<Note>,
}

impl<'a> Reader<'a> {
    /// A reader of `params` for the pattern `pattern` whose parameters are `specs`, in
    /// the recipe's segment `segment` (0-based, for notes). Checks every given key and
    /// the type of every value (a choice must be one of its options, text at most its
    /// length); numbers out of range are clamped later, when read.
    ///
    /// # Errors
    /// [`CreateError::UnknownParam`] or [`CreateError::WrongType`].
    pub fn new(
        pattern: &'static str,
        specs: &'static [ParamSpec],
        params: &'a Params,
        segment: usize,
    ) -> Result<Self, CreateError> {
        for (key, value) in params {
            let Some(spec) = specs.iter().find(|spec| spec.key == key) else {
                return Err(CreateError::UnknownParam {
                    pattern: pattern.to_owned(),
                    key: key.clone(),
                    known: specs
                        .iter()
                        .map(|spec| spec.key)
                        .collect::<Vec<_>>()
                        .join(", "),
                });
            };
            let fits = match (spec.kind, value) {
                (ParamKind::Number { .. }, Value::Number(value)) => value.is_finite(),
                (ParamKind::Choice { options, .. }, Value::Text(text)) => {
                    options.contains(&text.as_str())
                }
                (ParamKind::Text { max_chars, .. }, Value::Text(text)) => {
                    text.chars().count() <= max_chars
                }
                (ParamKind::Bytes { .. }, Value::Text(_)) => true,
                _ => false,
            };
            if !fits {
                return Err(CreateError::WrongType {
                    pattern: pattern.to_owned(),
                    key: key.clone(),
                    expected: spec.kind.expected(),
                });
            }
        }
        Ok(Self {
            pattern,
            specs,
            params,
            segment,
            notes: Vec::new(),
        })
    }

    fn spec(&self, key: &str) -> Option<&'static ParamSpec> {
        self.specs.iter().find(|spec| spec.key == key)
    }

    /// The number `key`: its value clamped into its range (with a note when clamped),
    /// or its default. A key the pattern does not describe reads 0.
    pub fn number(&mut self, key: &str) -> f64 {
        let Some(spec) = self.spec(key) else {
            return 0.0;
        };
        let ParamKind::Number {
            min,
            max,
            default,
            unit,
            ..
        } = spec.kind
        else {
            return 0.0;
        };
        let Some(Value::Number(value)) = self.params.get(key) else {
            return default;
        };
        let clamped = value.max(min).min(max);
        if clamped != *value {
            self.notes.push(Note::number(
                self.segment,
                self.pattern,
                key,
                (*value, clamped),
                unit,
                format!("(the range is {} to {})", number(min), number(max)),
            ));
        }
        clamped
    }

    /// The choice `key`: its value or its default. A key the pattern does not describe
    /// reads "".
    #[must_use]
    pub fn choice(&self, key: &str) -> &str {
        match (self.spec(key).map(|spec| spec.kind), self.params.get(key)) {
            (Some(ParamKind::Choice { .. }), Some(Value::Text(text))) => text,
            (Some(ParamKind::Choice { default, .. }), _) => default,
            _ => "",
        }
    }

    /// The text `key`: its value or its default. A key the pattern does not describe
    /// reads "".
    #[must_use]
    pub fn text(&self, key: &str) -> &str {
        match (self.spec(key).map(|spec| spec.kind), self.params.get(key)) {
            (Some(ParamKind::Text { .. }), Some(Value::Text(text))) => text,
            (Some(ParamKind::Text { default, .. }), _) => default,
            _ => "",
        }
    }

    /// The file `key`, decoded from base64; empty when none is given.
    ///
    /// # Errors
    /// [`CreateError::WrongType`] if it is not base64, [`CreateError::TooLarge`] if
    /// larger than the parameter allows.
    pub fn bytes(&self, key: &str) -> Result<Vec<u8>, CreateError> {
        let Some(spec) = self.spec(key) else {
            return Ok(Vec::new());
        };
        let ParamKind::Bytes { max_bytes } = spec.kind else {
            return Ok(Vec::new());
        };
        let Some(Value::Text(text)) = self.params.get(key) else {
            return Ok(Vec::new());
        };
        // Refuse before decoding: base64 takes 4 characters for 3 bytes.
        let estimate = text.len() / 4 * 3;
        if estimate > max_bytes.saturating_add(3) {
            return Err(CreateError::TooLarge {
                key: key.to_owned(),
                bytes: estimate,
                max_bytes,
            });
        }
        let bytes = decode_base64(text).ok_or_else(|| CreateError::WrongType {
            pattern: self.pattern.to_owned(),
            key: key.to_owned(),
            expected: "a file as base64 text (A–Z, a–z, 0–9, +, /, = padding)".to_owned(),
        })?;
        if bytes.len() > max_bytes {
            return Err(CreateError::TooLarge {
                key: key.to_owned(),
                bytes: bytes.len(),
                max_bytes,
            });
        }
        Ok(bytes)
    }

    /// The pattern's name.
    #[must_use]
    pub fn pattern(&self) -> &'static str {
        self.pattern
    }

    /// The notes of the values clamped so far.
    #[must_use]
    pub fn notes(&self) -> &[Note] {
        &self.notes
    }

    /// Adds a note (a builder that changes a value for the grid, e.g. a size that
    /// does not fit it).
    pub fn note(&mut self, key: &str, from: f64, to: f64, unit: &str, reason: &str) {
        self.notes.push(Note::number(
            self.segment,
            self.pattern,
            key,
            (from, to),
            unit,
            reason.to_owned(),
        ));
    }

    /// Adds a note that the characters `chars` of the text `key` are not in the
    /// built-in font (and are drawn as `?`); nothing if `chars` is empty.
    pub fn not_in_font(&mut self, key: &str, chars: String, reason: &str) {
        if chars.is_empty() {
            return;
        }
        self.change(key, Change::NotInFont { chars }, reason);
    }

    /// Adds a note of any other `change` to what the parameter `key` asked for, and
    /// `reason`: what to do instead.
    pub fn change(&mut self, key: &str, change: Change, reason: &str) {
        self.notes.push(Note {
            segment: self.segment,
            pattern: self.pattern.to_owned(),
            key: key.to_owned(),
            change,
            reason: reason.to_owned(),
        });
    }

    /// The notes, ending the reading.
    #[must_use]
    pub fn into_notes(self) -> Vec<Note> {
        self.notes
    }
}

const BASE64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// `bytes` as standard base64 with `=` padding.
#[must_use]
pub fn encode_base64(bytes: &[u8]) -> String {
    let mut text = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                text.push(char::from(BASE64[((n >> (18 - 6 * i)) & 63) as usize]));
            } else {
                text.push('=');
            }
        }
    }
    text
}

/// Marks a byte that is not a base64 digit in [`BASE64_VALUE`].
const NOT_BASE64: u8 = 0xff;

/// Each byte's value as a base64 digit (a table: a picture of a few MB is decoded on
/// every change of the Create page's sliders).
const BASE64_VALUE: [u8; 256] = {
    let mut table = [NOT_BASE64; 256];
    let mut digit = 0;
    while digit < BASE64.len() {
        table[BASE64[digit] as usize] = digit as u8;
        digit += 1;
    }
    table
};

/// Standard base64 (padding optional, ASCII whitespace ignored) as bytes; `None` if it
/// is not base64.
#[must_use]
pub fn decode_base64(text: &str) -> Option<Vec<u8>> {
    let mut bytes = Vec::with_capacity(text.len() / 4 * 3);
    let (mut acc, mut bits, mut padding) = (0u32, 0u32, 0usize);
    for c in text.bytes() {
        if c.is_ascii_whitespace() {
            continue;
        }
        if c == b'=' {
            padding += 1;
            continue;
        }
        if padding > 0 {
            return None;
        }
        let value = BASE64_VALUE[usize::from(c)];
        if value == NOT_BASE64 {
            return None;
        }
        acc = (acc << 6) | u32::from(value);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            bytes.push(u8::try_from((acc >> bits) & 0xff).ok()?);
        }
    }
    // Leftover bits must be the zero padding of the last character.
    if padding > 2 || bits >= 6 || acc & ((1 << bits) - 1) != 0 {
        return None;
    }
    Some(bytes)
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    const SPECS: &[ParamSpec] = &[
        ParamSpec {
            key: "size_mm",
            label: "Size",
            help: "How big.",
            kind: ParamKind::Number {
                min: 10.0,
                max: 100.0,
                step: 1.0,
                default: 50.0,
                unit: "mm",
            },
        },
        ParamSpec {
            key: "direction",
            label: "Direction",
            help: "Which way.",
            kind: ParamKind::Choice {
                options: &["left", "right"],
                default: "right",
            },
        },
        ParamSpec {
            key: "text",
            label: "Text",
            help: "What to say.",
            kind: ParamKind::Text {
                default: "HI",
                max_chars: 4,
            },
        },
        ParamSpec {
            key: "image",
            label: "Picture",
            help: "A picture.",
            kind: ParamKind::Bytes { max_bytes: 5 },
        },
    ];

    fn params(pairs: &[(&str, Value)]) -> Params {
        pairs
            .iter()
            .map(|(key, value)| ((*key).to_owned(), value.clone()))
            .collect()
    }

    #[test]
    fn missing_values_read_their_defaults() {
        let empty = Params::new();
        let mut reader = Reader::new("p", SPECS, &empty, 2).unwrap();
        assert_eq!(reader.number("size_mm"), 50.0);
        assert_eq!(reader.choice("direction"), "right");
        assert_eq!(reader.text("text"), "HI");
        assert_eq!(reader.bytes("image").unwrap(), Vec::<u8>::new());
        assert!(reader.notes().is_empty());
        // Keys the pattern does not describe (a builder's mistake) do not panic.
        assert_eq!(reader.number("nope"), 0.0);
        assert_eq!(reader.number("direction"), 0.0);
        assert_eq!(reader.choice("size_mm"), "");
        assert_eq!(reader.text("nope"), "");
    }

    #[test]
    fn numbers_out_of_range_are_clamped_with_a_note() {
        let given = params(&[("size_mm", Value::Number(5.0))]);
        let mut reader = Reader::new("p", SPECS, &given, 2).unwrap();
        assert_eq!(reader.number("size_mm"), 10.0);
        let notes = reader.into_notes();
        assert_eq!(notes.len(), 1);
        assert_eq!(
            (notes[0].segment, notes[0].numbers()),
            (2, Some((5.0, 10.0)))
        );
        assert_eq!(
            notes[0].to_string(),
            "size_mm of p 3 clamped from 5 to 10 mm (the range is 10 to 100)"
        );
        let given = params(&[("size_mm", Value::Number(70.0))]);
        let mut reader = Reader::new("p", SPECS, &given, 0).unwrap();
        assert_eq!(reader.number("size_mm"), 70.0);
        assert!(reader.notes().is_empty());
    }

    #[test]
    fn unknown_keys_and_wrong_types_are_refused_in_words() {
        let error =
            Reader::new("p", SPECS, &params(&[("sise_mm", Value::Number(5.0))]), 0).unwrap_err();
        assert_eq!(
            error.to_string(),
            "pattern \"p\" has no parameter \"sise_mm\"; its parameters are: size_mm, \
             direction, text, image"
        );
        let refused = |key: &str, value: Value| {
            Reader::new("p", SPECS, &params(&[(key, value)]), 0)
                .unwrap_err()
                .to_string()
        };
        assert_eq!(
            refused("size_mm", Value::Text("big".into())),
            "parameter \"size_mm\" of pattern \"p\" must be a number from 10 to 100 mm"
        );
        assert_eq!(
            refused("direction", Value::Text("up".into())),
            "parameter \"direction\" of pattern \"p\" must be one of: left, right"
        );
        assert!(refused("text", Value::Text("HELLO".into())).contains("at most 4 characters"));
        assert!(refused("image", Value::Number(1.0)).contains("base64"));
        assert!(refused("size_mm", Value::Number(f64::NAN)).contains("a number"));
    }

    #[test]
    fn files_are_base64_within_their_size() {
        let given = params(&[("image", Value::Text(encode_base64(b"abcd")))]);
        let reader = Reader::new("p", SPECS, &given, 0).unwrap();
        assert_eq!(reader.bytes("image").unwrap(), b"abcd");
        let given = params(&[("image", Value::Text(encode_base64(b"abcdefghijk")))]);
        let error = Reader::new("p", SPECS, &given, 0)
            .unwrap()
            .bytes("image")
            .unwrap_err();
        assert!(
            matches!(error, CreateError::TooLarge { max_bytes: 5, .. }),
            "{error}"
        );
        let given = params(&[("image", Value::Text("not base64!".into()))]);
        let error = Reader::new("p", SPECS, &given, 0)
            .unwrap()
            .bytes("image")
            .unwrap_err();
        assert!(error.to_string().contains("base64"), "{error}");
    }

    #[test]
    fn base64_round_trips_and_refuses_garbage() {
        for bytes in [&b""[..], b"f", b"fo", b"foo", b"foob", b"fooba", b"foobar"] {
            let text = encode_base64(bytes);
            assert_eq!(decode_base64(&text).as_deref(), Some(bytes), "{text}");
        }
        assert_eq!(encode_base64(b"foobar"), "Zm9vYmFy");
        assert_eq!(encode_base64(b"fo"), "Zm8=");
        assert_eq!(decode_base64("Zm8").as_deref(), Some(&b"fo"[..]));
        assert_eq!(decode_base64("Zm 9v\nYg==").as_deref(), Some(&b"foob"[..]));
        assert_eq!(decode_base64("Zm9=v"), None);
        assert_eq!(decode_base64("Z"), None);
        assert_eq!(decode_base64("Zm9*"), None);
        assert_eq!(decode_base64("Zm9vYg==="), None);
        // Every byte value, through every digit; bytes above ASCII are not digits.
        let all: Vec<u8> = (0..=255).collect();
        assert_eq!(decode_base64(&encode_base64(&all)), Some(all));
        assert_eq!(decode_base64("Zm9\u{e9}"), None);
        assert_eq!(decode_base64("Zm9-"), None);
    }

    #[test]
    fn values_are_untagged_in_json() {
        let given = params(&[("a", Value::Number(1.5)), ("b", Value::Text("left".into()))]);
        let json = serde_json::to_string(&given).unwrap();
        assert_eq!(json, r#"{"a":1.5,"b":"left"}"#);
        assert_eq!(serde_json::from_str::<Params>(&json).unwrap(), given);
        let kind = SPECS[0].kind;
        assert_eq!(kind.default_value(), Some(Value::Number(50.0)));
        assert_eq!(SPECS[3].kind.default_value(), None);
    }
}
