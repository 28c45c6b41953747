//! Property tests of show creation (issue 19): for every pattern and any parameters
//! within the ranges the page allows, on small grids, the rendered show passes
//! validation; position and velocity are continuous across segment and transition
//! boundaries; the same recipe renders the same show.
#![cfg(not(target_arch = "wasm32"))]

use floatball_shared::create::params::ParamKind;
use floatball_shared::create::{
    Grid, PATTERNS, Params, PatternSpec, Recipe, Segment, Value, pattern, render,
};
use floatball_shared::show::{Limits, Show, validate};
use proptest::prelude::*;

/// Patterns that need no file (a picture has no default).
fn usable() -> Vec<&'static PatternSpec> {
    PATTERNS
        .iter()
        .filter(|spec| {
            !spec
                .params
                .iter()
                .any(|param| matches!(param.kind, ParamKind::Bytes { .. }))
        })
        .collect()
}

/// Parameters for `spec` from `draws` (each in 0..1): numbers on any step of their
/// range (nearly a third of them at an end), choices any option, text its default.
fn params_for(spec: &PatternSpec, draws: &[f64]) -> Params {
    spec.params
        .iter()
        .zip(draws.iter().cycle())
        .filter_map(|(param, &draw)| {
            let value = match param.kind {
                ParamKind::Number { min, max, step, .. } => {
                    let at = if draw < 0.15 {
                        0.0
                    } else if draw > 0.85 {
                        1.0
                    } else {
                        (draw - 0.15) / 0.7
                    };
                    // On the slider's steps, as the page gives them.
                    Value::Number((min + (at * (max - min) / step).round() * step).min(max))
                }
                ParamKind::Choice { options, .. } => Value::Text(
                    options[((draw * options.len() as f64) as usize).min(options.len() - 1)]
                        .to_owned(),
                ),
                ParamKind::Text { .. } | ParamKind::Bytes { .. } => return None,
            };
            Some((param.key.to_owned(), value))
        })
        .collect()
}

fn limits_for(grid: &Grid) -> Limits {
    let mut limits = Limits::for_layout(grid.rows, grid.cols);
    limits.travel_mm = grid.travel_mm;
    limits
}

/// Checks the rows are continuous: between adjacent rows the position moves at most
/// what the top speed allows and the velocity changes at most what the top
/// acceleration allows (the rows are the units' Hermite cubics, whose peaks
/// validation checks too).
fn assert_continuous(show: &Show, limits: &Limits) {
    for track in &show.tracks {
        let (mut p0, mut v0) = (track.start_mm, 0.0f64);
        for row in &track.rows {
            let dt_s = f64::from(row.duration_ms) / 1000.0;
            assert!((row.position_mm - p0).abs() <= limits.max_speed_mm_s * dt_s + 1e-6);
            assert!((row.velocity_mm_s - v0).abs() <= limits.max_accel_mm_s2 * dt_s + 1e-6);
            (p0, v0) = (row.position_mm, row.velocity_mm_s);
        }
        assert_eq!(v0, 0.0, "ends at rest");
    }
}

fn grid_strategy() -> impl Strategy<Value = Grid> {
    (1u32..=12, 1u32..=12, 200.0f64..1500.0, 1500.0f64..7500.0)
        .prop_map(|(rows, cols, pitch_mm, travel_mm)| Grid::new(rows, cols, pitch_mm, travel_mm))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn every_pattern_with_any_parameters_stays_within_the_limits(
        which in 0usize..64,
        draws in prop::collection::vec(0.0f64..1.0, 8),
        grid in grid_strategy(),
        duration_s in 2.0f64..20.0,
        row_ms in prop::sample::select(vec![20u32, 50, 100, 200, 255]),
    ) {
        let patterns = usable();
        let spec = patterns[which % patterns.len()];
        let mut recipe = Recipe::single("p", spec.name, params_for(spec, &draws), duration_s);
        recipe.row_ms = row_ms;
        let limits = limits_for(&grid);
        let generated = render(&recipe, &grid, &limits).unwrap();
        prop_assert_eq!(validate(&generated.show, &limits), vec![], "{} {:?}", spec.name, recipe);
        assert_continuous(&generated.show, &limits);
    }

}

proptest! {
    // Fewer: a timeline with slow limits may have transitions of up to a minute.
    #![proptest_config(ProptestConfig { cases: 24, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn timelines_with_transitions_stay_within_the_limits_and_continuous(
        picks in prop::collection::vec((0usize..64, 0.5f64..8.0, 0.5f64..4.0), 1..4),
        draws in prop::collection::vec(0.0f64..1.0, 8),
        grid in grid_strategy(),
        slow in any::<bool>(),
    ) {
        let patterns = usable();
        let segments = picks
            .iter()
            .enumerate()
            .map(|(index, &(which, duration_s, transition_s))| {
                let spec = patterns[which % patterns.len()];
                let draws: Vec<f64> = draws.iter().map(|d| (d + index as f64 * 0.37) % 1.0).collect();
                // Tenths of a second, as the page's fields give them.
                Segment {
                    pattern: spec.name.to_owned(),
                    params: params_for(spec, &draws),
                    duration_s: (duration_s * 10.0).round() / 10.0,
                    transition_s: (transition_s * 10.0).round() / 10.0,
                }
            })
            .collect();
        let recipe = Recipe { name: "t".into(), row_ms: 100, grid: None, segments };
        let mut limits = limits_for(&grid);
        if slow {
            // A gentler installation.
            limits.max_speed_mm_s = 600.0;
            limits.max_accel_mm_s2 = 800.0;
        }
        let generated = render(&recipe, &grid, &limits).unwrap();
        prop_assert_eq!(validate(&generated.show, &limits), vec![]);
        assert_continuous(&generated.show, &limits);
        // A recipe file renders the same show every time, and reads back as itself.
        let json = recipe.to_json().unwrap();
        let read = Recipe::from_json(&json).unwrap();
        prop_assert_eq!(&read.to_json().unwrap(), &json);
        let once = render(&read, &grid, &limits).unwrap();
        let twice = render(&Recipe::from_json(&json).unwrap(), &grid, &limits).unwrap();
        prop_assert_eq!(once.show.to_json().unwrap(), twice.show.to_json().unwrap());
        prop_assert_eq!(once.notes, twice.notes);
    }
}

fn wave_params(pairs: &[(&str, f64)]) -> Params {
    pairs
        .iter()
        .map(|(key, value)| ((*key).to_owned(), Value::Number(*value)))
        .collect()
}

/// The rows at their times are the patterns' positions: the first's while it runs
/// alone, the second's once the transition is over, blended in between.
#[test]
fn rows_follow_the_patterns_across_the_transition() {
    let grid = Grid::new(3, 4, 500.0, 7500.0);
    let first = wave_params(&[("speed_m_s", 0.4)]);
    let second = wave_params(&[("centre_mm", 4000.0), ("amplitude_mm", 500.0)]);
    let recipe = Recipe {
        name: "two".into(),
        row_ms: 100,
        grid: None,
        segments: vec![
            Segment {
                pattern: "wave".into(),
                params: first.clone(),
                duration_s: 6.0,
                transition_s: 5.0,
            },
            Segment {
                pattern: "wave".into(),
                params: second.clone(),
                duration_s: 6.0,
                transition_s: 2.0,
            },
        ],
    };
    let limits = limits_for(&grid);
    let generated = render(&recipe, &grid, &limits).unwrap();
    assert!(generated.notes.is_empty(), "{:?}", generated.notes);
    // The show eases in and out over 2 s: 1 s longer at each end.
    assert_eq!(generated.show.duration_ms(), 19_000);
    let wave = pattern("wave").unwrap();
    let (a, _) = wave.field(&first, 0, &grid).unwrap();
    let (b, _) = wave.field(&second, 1, &grid).unwrap();
    let mut expected = vec![0.0; 12];
    // The row ending at timeline time `t_s` (show time t_s + 1 s).
    let row_at = |unit: usize, t_s: f64| {
        let row = ((t_s + 1.0) * 10.0).round() as usize - 1;
        generated.show.tracks[unit].rows[row].position_mm
    };
    for t_s in [2.0, 3.5, 5.9] {
        a.sample(&grid, t_s, &mut expected);
        for (unit, mm) in expected.iter().enumerate() {
            assert!(
                (row_at(unit, t_s) - mm).abs() <= 0.05 + 1e-9,
                "{t_s} s ball {unit}"
            );
        }
    }
    // The second wave's own time starts with the transition, at 6 s.
    for t_s in [11.5, 13.0, 16.0] {
        b.sample(&grid, t_s - 6.0, &mut expected);
        for (unit, mm) in expected.iter().enumerate() {
            assert!(
                (row_at(unit, t_s) - mm).abs() <= 0.05 + 1e-9,
                "{t_s} s ball {unit}"
            );
        }
    }
    // In the middle of the transition: halfway between the two.
    let mut other = vec![0.0; 12];
    a.sample(&grid, 8.5, &mut expected);
    b.sample(&grid, 2.5, &mut other);
    for unit in 0..12 {
        let half = (expected[unit] + other[unit]) / 2.0;
        assert!((row_at(unit, 8.5) - half).abs() <= 0.05 + 1e-9);
    }
    // At rest at both ends: the first row starts where the first wave starts, the
    // last ends where the second wave is at the end of the timeline (17 s).
    a.sample(&grid, 0.0, &mut expected);
    b.sample(&grid, 11.0, &mut other);
    for ((track, start), end) in generated.show.tracks.iter().zip(&expected).zip(&other) {
        assert!((track.start_mm - start).abs() <= 0.05 + 1e-9);
        let last = track.rows.last().unwrap();
        assert!((last.position_mm - end).abs() <= 0.05 + 1e-9);
        assert_eq!(last.velocity_mm_s, 0.0);
    }
}

#[test]
fn every_pattern_with_its_defaults_renders_without_a_note() {
    let grid = Grid::new(10, 10, 500.0, 7500.0);
    let limits = limits_for(&grid);
    for spec in usable() {
        let recipe = Recipe::single("d", spec.name, Params::new(), 20.0);
        let generated = render(&recipe, &grid, &limits).unwrap();
        assert!(
            generated.notes.is_empty(),
            "{}: {:?}",
            spec.name,
            generated.notes
        );
        assert_eq!(validate(&generated.show, &limits), []);
        // And it moves.
        let track = &generated.show.tracks[37];
        let moved = track
            .rows
            .iter()
            .any(|row| (row.position_mm - track.start_mm).abs() > 100.0);
        assert!(moved, "{} does not move", spec.name);
    }
}

#[test]
fn too_much_is_scaled_down_with_a_note_naming_the_parameter() {
    let grid = Grid::new(6, 6, 500.0, 7500.0);
    let limits = limits_for(&grid);
    // 3 m swing at 5 m/s over 1 m waves: far too fast.
    let params = wave_params(&[
        ("amplitude_mm", 3000.0),
        ("speed_m_s", 5.0),
        ("wavelength_m", 1.0),
    ]);
    let generated = render(
        &Recipe::single("fast", "wave", params, 10.0),
        &grid,
        &limits,
    )
    .unwrap();
    assert_eq!(validate(&generated.show, &limits), []);
    let note = generated
        .notes
        .iter()
        .find(|note| note.reason.contains("mm/s"))
        .unwrap();
    assert_eq!(
        (note.segment, note.key.as_str(), note.numbers().unwrap().0),
        (0, "amplitude_mm", 3000.0)
    );
    assert!(note.numbers().unwrap().1 < 3000.0 * 0.2, "{note}");
    assert!(
        note.to_string()
            .starts_with("amplitude_mm of wave 1 clamped from 3000 to "),
        "{note}"
    );
    // A wave around a middle too low for its swing is moved up, naming the height.
    let params = wave_params(&[
        ("centre_mm", 7400.0),
        ("amplitude_mm", 1000.0),
        ("speed_m_s", 0.2),
    ]);
    let generated = render(&Recipe::single("low", "wave", params, 10.0), &grid, &limits).unwrap();
    assert_eq!(validate(&generated.show, &limits), []);
    let note = &generated.notes[0];
    let (from, to) = note.numbers().unwrap();
    assert_eq!((note.key.as_str(), from), ("centre_mm", 7400.0));
    assert!((to - (7500.0 - 150.0 - 1000.0)).abs() < 20.0, "{note}");
    // A transition too short for the distance between its patterns is lengthened.
    let recipe = Recipe {
        name: "jump".into(),
        row_ms: 200,
        grid: None,
        segments: vec![
            Segment {
                pattern: "breathe".into(),
                params: wave_params(&[
                    ("centre_mm", 500.0),
                    ("amplitude_mm", 0.0),
                    ("dome_mm", 0.0),
                ]),
                duration_s: 3.0,
                transition_s: 0.5,
            },
            Segment {
                pattern: "breathe".into(),
                params: wave_params(&[
                    ("centre_mm", 7000.0),
                    ("amplitude_mm", 0.0),
                    ("dome_mm", 0.0),
                ]),
                duration_s: 3.0,
                transition_s: 2.0,
            },
        ],
    };
    let generated = render(&recipe, &grid, &limits).unwrap();
    assert_eq!(validate(&generated.show, &limits), []);
    assert_eq!(generated.notes.len(), 1, "{:?}", generated.notes);
    let note = &generated.notes[0];
    assert_eq!(
        (note.segment, note.key.as_str(), note.numbers().unwrap().0),
        (0, "transition_s", 0.5)
    );
    let longer_s = note.numbers().unwrap().1;
    // 6500 mm in at most half of 2000 mm/s: the smooth step needs 1.875 × 6500 / 1000
    // = 12.2 s.
    assert!((12.0..13.0).contains(&longer_s), "{note}");
    assert_eq!(
        generated.show.duration_ms(),
        // Whole rows of 200 ms.
        ((6.0 + longer_s + 2.0) / 0.2 - 1e-9).ceil() as u64 * 200
    );
    // Beyond the longest transition, the whole show's motion is scaled down, and the
    // note says which transition it is.
    let mut slow = limits;
    slow.max_speed_mm_s = 50.0;
    let generated = render(&recipe, &grid, &slow).unwrap();
    assert_eq!(validate(&generated.show, &slow), []);
    assert_eq!(generated.notes[0].numbers().unwrap().1, 60.0);
    let note = generated.notes.last().unwrap();
    assert_eq!(note.key, "motion");
    assert!(
        note.to_string().contains(
            "the blend from segment 1 into 2 is the hardest part, its transition_s at its \
             longest: bring the two patterns' heights closer"
        ),
        "{note}"
    );
}

#[test]
fn bad_input_is_refused_in_words() {
    let grid = Grid::new(2, 2, 500.0, 7500.0);
    let limits = limits_for(&grid);
    let error = render(
        &Recipe::single("x", "waves", Params::new(), 5.0),
        &grid,
        &limits,
    )
    .unwrap_err();
    assert!(
        error
            .to_string()
            .contains("there is no pattern \"waves\"; the patterns are: wave, ripple"),
        "{error}"
    );
    let error = render(
        &Recipe::single("x", "wave", wave_params(&[("size", 1.0)]), 5.0),
        &grid,
        &limits,
    )
    .unwrap_err();
    assert!(
        error.to_string().contains("has no parameter \"size\""),
        "{error}"
    );
    let error = render(
        &Recipe::single("x", "wave", Params::new(), 5.0),
        &Grid::new(0, 2, 500.0, 7500.0),
        &limits,
    )
    .unwrap_err();
    assert!(error.to_string().contains("at least one row"), "{error}");
    // More rows than a renderer holds: refused before any is made.
    let grid = Grid::new(1000, 1000, 500.0, 7500.0);
    let error = render(
        &Recipe::single("x", "wave", Params::new(), 60.0),
        &grid,
        &limits_for(&grid),
    )
    .unwrap_err();
    assert!(
        error.to_string().starts_with(
            "the show would have 310 rows for each of 1000000 balls, 310000000 in all"
        ),
        "{error}"
    );
}

/// docs/create.md describes every pattern and every parameter with its range and
/// default, as the table holds them.
#[test]
fn the_documentation_lists_every_pattern_and_parameter() {
    let doc = include_str!("../../docs/create.md");
    for spec in PATTERNS {
        let heading = format!("### `{}`", spec.name);
        let Some(start) = doc.find(&heading) else {
            panic!("docs/create.md: add a section for pattern {}", spec.name);
        };
        let section = &doc[start + heading.len()..];
        let section = &section[..section.find("\n#").unwrap_or(section.len())];
        for param in spec.params {
            let row = section
                .lines()
                .find(|line| line.starts_with(&format!("| `{}` | {} |", param.key, param.label)));
            let Some(row) = row else {
                panic!(
                    "docs/create.md: add a row for `{}` of pattern {}",
                    param.key, spec.name
                );
            };
            if let ParamKind::Number {
                min,
                max,
                default,
                unit,
                ..
            } = param.kind
            {
                let expected = format!("| {unit} | {min}–{max} | {default} |");
                assert!(row.ends_with(&expected), "{row} should end {expected}");
            }
        }
    }
}
