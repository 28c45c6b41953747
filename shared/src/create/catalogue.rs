//! The catalogue of patterns: [`PATTERNS`] holds every pattern's name, label, help
//! line, parameters (as data) and builder, in the order the app and the CLI list them;
//! [`pattern()`] finds one by name.
//!
//! ```
//! use floatball_shared::create::{Grid, Params, pattern};
//!
//! let wave = pattern("wave").unwrap();
//! let grid = Grid::new(10, 10, 500.0, 7500.0);
//! let (field, notes) = wave.field(&Params::new(), 0, &grid).unwrap();
//! assert!(notes.is_empty());
//! let mut out_mm = vec![0.0; grid.unit_count()];
//! field.sample(&grid, 1.0, &mut out_mm);
//! assert!(out_mm.iter().all(|&mm| (0.0..=7500.0).contains(&mm)));
//! ```

use super::params::{ParamSpec, Params, Reader};
use super::{CreateError, Field, Grid, Note};

/// A pattern: what the page lists, the CLI offers and a recipe names.
#[derive(Debug, Clone, Copy)]
pub struct PatternSpec {
    /// Its name in recipes and on the CLI (`"wave"`, `"ripple"`, …).
    pub name: &'static str,
    /// English label; the app translates by name.
    pub label: &'static str,
    /// One sentence: what it does.
    pub help: &'static str,
    /// Its parameters.
    pub params: &'static [ParamSpec],
    /// Builds the field from its parameters (read with the reader) for a grid.
    pub build: Build,
}

/// A pattern's builder: reads its parameters (with the reader) and builds its field
/// for the grid, computing every per-ball constant so [`Field::sample`] is cheap.
pub type Build = fn(&mut Reader<'_>, &Grid) -> Result<Box<dyn Field>, CreateError>;

impl PatternSpec {
    /// The parameter `key`, if the pattern has it.
    #[must_use]
    pub fn param(&self, key: &str) -> Option<&'static ParamSpec> {
        self.params.iter().find(|spec| spec.key == key)
    }

    /// The field of this pattern with `params` for `grid`, in segment `segment` of a
    /// recipe (for the notes), and the notes of the values clamped into range.
    ///
    /// # Errors
    /// An unknown parameter, a value of the wrong type, a file that cannot be used.
    pub fn field(
        &self,
        params: &Params,
        segment: usize,
        grid: &Grid,
    ) -> Result<(Box<dyn Field>, Vec<Note>), CreateError> {
        let mut reader = Reader::new(self.name, self.params, params, segment)?;
        let field = (self.build)(&mut reader, grid)?;
        Ok((field, reader.into_notes()))
    }
}

/// Every pattern, in the order they are listed.
pub const PATTERNS: &[PatternSpec] = &[
    super::wave::PATTERN,
    super::ripple::PATTERN,
    super::rain::PATTERN,
    super::plane::PATTERN,
    super::breathe::PATTERN,
    super::noise::PATTERN,
    super::text::PATTERN,
    super::picture::PATTERN,
];

/// The pattern called `name`.
#[must_use]
pub fn pattern(name: &str) -> Option<&'static PatternSpec> {
    PATTERNS.iter().find(|spec| spec.name == name)
}

/// The pattern called `name`, or an error listing the patterns.
///
/// # Errors
/// [`CreateError::UnknownPattern`].
pub fn find(name: &str) -> Result<&'static PatternSpec, CreateError> {
    pattern(name).ok_or_else(|| CreateError::UnknownPattern {
        name: name.to_owned(),
        known: names(),
    })
}

/// The patterns' names, comma-separated.
#[must_use]
pub fn names() -> String {
    PATTERNS
        .iter()
        .map(|spec| spec.name)
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::params::ParamKind;
    use super::*;

    #[test]
    fn names_and_keys_are_unique_and_described() {
        for (index, spec) in PATTERNS.iter().enumerate() {
            assert!(
                PATTERNS[..index]
                    .iter()
                    .all(|other| other.name != spec.name),
                "{} twice",
                spec.name
            );
            assert!(
                !spec.label.is_empty() && spec.help.ends_with('.'),
                "{}",
                spec.name
            );
            for (at, param) in spec.params.iter().enumerate() {
                assert!(
                    spec.params[..at].iter().all(|other| other.key != param.key),
                    "{}.{} twice",
                    spec.name,
                    param.key
                );
                assert!(param.help.ends_with('.'), "{}.{}", spec.name, param.key);
                assert!(!param.label.is_empty());
                match param.kind {
                    ParamKind::Number {
                        min,
                        max,
                        step,
                        default,
                        ..
                    } => {
                        assert!(min < max && step > 0.0, "{}.{}", spec.name, param.key);
                        assert!(
                            (min..=max).contains(&default),
                            "{}.{}",
                            spec.name,
                            param.key
                        );
                    }
                    ParamKind::Choice { options, default } => {
                        assert!(options.contains(&default), "{}.{}", spec.name, param.key);
                    }
                    ParamKind::Text { default, max_chars } => {
                        assert!(default.chars().count() <= max_chars);
                    }
                    ParamKind::Bytes { max_bytes } => assert!(max_bytes > 0),
                }
            }
        }
    }

    #[test]
    fn every_pattern_builds_with_its_defaults_within_the_travel() {
        let grid = Grid::new(10, 10, 500.0, 7500.0);
        let mut out_mm = vec![f64::NAN; grid.unit_count()];
        for spec in PATTERNS {
            if spec
                .params
                .iter()
                .any(|param| matches!(param.kind, ParamKind::Bytes { .. }))
            {
                continue; // needs a file
            }
            let (field, notes) = spec.field(&Params::new(), 0, &grid).unwrap();
            assert!(notes.is_empty(), "{}: {notes:?}", spec.name);
            for t_s in [0.0, 0.7, 5.0, 31.3] {
                field.sample(&grid, t_s, &mut out_mm);
                assert!(
                    out_mm
                        .iter()
                        .all(|&mm| (0.0..=grid.travel_mm).contains(&mm)),
                    "{} at {t_s} s: {out_mm:?}",
                    spec.name
                );
            }
        }
    }

    #[test]
    fn unknown_patterns_are_refused_with_the_list() {
        assert!(pattern("wave").is_some());
        assert!(pattern("Wave").is_none());
        let error = find("wav").unwrap_err();
        assert!(
            error.to_string().contains("there is no pattern \"wav\""),
            "{error}"
        );
        assert!(error.to_string().contains("wave"), "{error}");
    }
}
